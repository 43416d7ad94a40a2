"""Compile the numba kernels once, ahead of the first node start (``setup.sh`` runs this).

The three compiled hot paths — skin_driver's calibration, contact_estimation's per-patch sums
and wholebody_controller's control step — cache their machine code next to their modules
(``cache=True``). The first compile costs tens of seconds (the control step ≈ 20–30 s on the
development machine); without this step it would fall on the first node start or the first test
that builds a controller, where a launch test waiting a few seconds for ``/cmd_vel`` could time
out. Later starts load the cache in well under a second; numba recompiles by itself when a
kernel's source changes.
"""

from __future__ import annotations

import time
from collections.abc import Callable


def _controller() -> None:
    from wholebody_controller.controller import WholeBodyController
    from wholebody_controller.kinematics import RobotKinematics

    WholeBodyController(RobotKinematics())  # configure() warms the compiled step up


def _estimator() -> None:
    from contact_estimation import patch_sums

    patch_sums.warm_up()


def _skin_driver() -> None:
    from skin_driver import frame_calibration

    frame_calibration.warm_up()


KERNELS: dict[str, Callable[[], None]] = {
    "skin_driver calibration": _skin_driver,
    "contact_estimation sums": _estimator,
    "wholebody_controller step": _controller,
}


def main() -> None:
    """Compile (or load) every kernel, printing the time each took."""
    for name, build in KERNELS.items():
        start = time.perf_counter()
        build()
        print(f"compile_kernels: {name} ready in {time.perf_counter() - start:.1f} s", flush=True)


if __name__ == "__main__":
    main()
