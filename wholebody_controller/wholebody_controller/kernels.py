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


def _cache_stem(dispatcher: Any) -> Path | None:
    """Where numba keeps ``dispatcher``'s machine code: its index file's path without ``.nbi``
    (the ``.nbc`` data files and our ``.sources`` stamp share that stem); None where numba lays
    its cache out otherwise (then numba's own rules apply)."""
    cache_file = getattr(getattr(dispatcher, "_cache", None), "_cache_file", None)
    index = getattr(cache_file, "_index_path", None)  # numba's private layout (0.68)
    if not isinstance(index, str | Path) or not str(index).endswith(".nbi"):
        return None
    return Path(str(index)[: -len(".nbi")])


def _drop_stale_cache(dispatchers: list[Any]) -> None:
    """Delete the entry points' cached machine code if the step's source changed since it was
    written (a fingerprint of :data:`STEP_MODULES` beside each cache)."""
    digest = hashlib.sha256(b"".join(inspect.getsource(m).encode() for m in STEP_MODULES))
    for dispatcher in dispatchers:
        stem = _cache_stem(dispatcher)
        if stem is None:
            continue
        stamp = stem.with_name(f"{stem.name}.sources")
        try:
            if stamp.exists() and stamp.read_text() == digest.hexdigest():
                continue
            for path in stem.parent.glob(f"{stem.name}*.nb[ic]"):
                path.unlink(missing_ok=True)
            stamp.write_text(digest.hexdigest())
        except OSError:  # a read-only install: numba then recompiles in memory
            pass
