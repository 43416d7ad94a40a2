"""The control step's kernel: the same functions compiled (numba) or interpreted (``kernel``).

The step is written once, as plain Python marked :func:`~phri_common.jit.jitable`
(:mod:`task_step`, :mod:`whole_step`). ``kernel: python`` runs those functions as they are —
the readable path, for debugging and for kinematics numba cannot take; ``kernel: numba``
(default) compiles the three entry points once per process (``cache=True``: the machine code is
stored beside the modules and loaded by later processes, ≈ 20 s the first time; ``setup.sh``
and ``test.sh`` compile ahead through :mod:`phri_bringup.compile_kernels`).

numba checks only the file of each entry point against its cache, not the modules it compiles
in; :func:`_drop_stale_cache` therefore deletes the entry points' cache whenever the source of
any module of the step changed.
"""

from __future__ import annotations

import functools
import hashlib
import inspect
from collections.abc import Callable
from pathlib import Path
from typing import Any, NamedTuple

from phri_common import planar
from wholebody_controller import (
    admittance,
    contact_safety,
    contact_task,
    following,
    linalg3,
    qp,
    region,
    so3,
    task_rows,
    task_step,
    whole_step,
)
from wholebody_controller.config import KERNELS

STEP_MODULES = (so3, linalg3, planar, admittance, contact_task, region, following,
                contact_safety, qp, task_rows, task_step, whole_step)
"""Every module whose functions the compiled entry points contain."""


class StepKernel(NamedTuple):
    """The entry points of one kernel (same signatures either way)."""

    name: str
    step_links: Callable[..., None]
    """:func:`~wholebody_controller.task_step.step_links`: every link's task step."""
    qp_of_step: Callable[..., bool]
    """:func:`~wholebody_controller.whole_step.qp_of_step`: (22)–(23) of a step."""
    step_robot: Callable[..., bool]
    """:func:`~wholebody_controller.whole_step.step_robot`: the whole step on MuJoCo frames."""


PYTHON = StepKernel("python", task_step.step_links, whole_step.qp_of_step,
                    whole_step.step_robot)


@functools.cache
def compiled() -> StepKernel:
    """The entry points compiled with numba (loaded from the cache when it is current)."""
    from numba import njit

    step_links = njit(cache=True)(task_step.step_links)
    qp_of_step = njit(cache=True)(whole_step.qp_of_step)
    step_robot = njit(cache=True)(whole_step.step_robot)
    _drop_stale_cache([step_links, qp_of_step, step_robot])
    return StepKernel("numba", step_links, qp_of_step, step_robot)


def step_kernel(name: str) -> StepKernel:
    """The kernel called ``name`` (one of :data:`KERNELS`).

    Raises:
        ValueError: an unknown name (the message names the parameter and the allowed values).
    """
    if name == "python":
        return PYTHON
    if name == "numba":
        return compiled()
    raise ValueError(f"parameter 'kernel' refused value {name!r}: allowed {', '.join(KERNELS)}")


def _drop_stale_cache(dispatchers: list[Any]) -> None:
    """Delete the entry points' cached machine code if the step's source changed since it was
    written (a fingerprint of :data:`STEP_MODULES` beside each cache)."""
    digest = hashlib.sha256(b"".join(inspect.getsource(m).encode() for m in STEP_MODULES))
    for dispatcher in dispatchers:
        try:
            cache = dispatcher._cache  # numba's per-function cache (private, stable since 0.49)
            folder = Path(cache._cache_path)
            stem = cache._index_name.rsplit(".nbi", 1)[0]
            stamp = folder / f"{stem}.sources"
            if stamp.exists() and stamp.read_text() == digest.hexdigest():
                continue
            for path in folder.glob(f"{stem}*.nb[ic]"):
                path.unlink(missing_ok=True)
            stamp.write_text(digest.hexdigest())
        except (OSError, AttributeError):  # read-only install, or a numba without this layout:
            pass  # numba then recompiles in memory or keeps its own rules
