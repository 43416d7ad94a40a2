"""A UR's speed scaling applied to the whole body's command (pure: numpy only).

The teach pendant's speed slider slows a UR's joints, not the base: the node scales the step's
command so that every axis moves at the slowest arm's fraction (:func:`scale_to_slowest`), or
commands zero below ``min_speed_scaling`` (:mod:`wholebody_controller.node`).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from numpy.typing import NDArray

ARM_COMMAND_SLICES: dict[str, slice] = {"left": slice(3, 9), "right": slice(9, 15)}
"""Each arm's joint velocities in the 15-element command (base x, y, yaw first)."""


def scale_to_slowest(command: NDArray[np.float64], scaling: Mapping[str, float]
                     ) -> NDArray[np.float64]:
    """The command that makes every axis move at the smallest speed scaling s = min(scaling):
    the base (no pendant slows it) and an arm without a reading × s, each arm with a reading
    s_arm × s / s_arm (its UR multiplies by s_arm itself), so the whole body keeps the direction
    the QP chose at s × its speed. Never amplifies (s / s_arm ≤ 1); no reading: unchanged.

    Args:
        command: base twist [m/s, m/s, rad/s] then 12 arm joint velocities [rad/s].
        scaling: executed fraction of commanded speed per arm, 0–1.
    """
    if not scaling:
        return command
    slowest = min(scaling.values())
    out = command * slowest
    for arm, part in ARM_COMMAND_SLICES.items():
        own = scaling.get(arm)
        if own is not None and own > 0.0:
            out[part] = command[part] * (slowest / own)
    return out


class ScalingGate:
    """The ``min_speed_scaling`` rule over time: whether a cycle must command zero because the
    slowest arm's speed scaling is below the minimum, when that began (the tasks are reset
    once) and the warning due (at most once a second: rclpy's own throttle costs milliseconds
    per call even when it throttles)."""

    def __init__(self) -> None:
        self.refused = False
        self._warned_ns: int | None = None

    def check(self, scaling: Mapping[str, float], minimum: float, now_ns: int
              ) -> tuple[bool, bool, str]:
        """``(refuse, began, warning)`` for this cycle at ``now_ns`` [ns]: whether to command
        zero, whether the refusal began now, the warning to log ('' = none due)."""
        slowest = min(scaling.values(), default=1.0)
        if slowest >= minimum:
            self.refused = False
            return False, False, ""
        began = not self.refused
        self.refused = True
        warning = ""
        if self._warned_ns is None or now_ns - self._warned_ns >= 1_000_000_000:
            self._warned_ns = now_ns
            arms = ", ".join(f"{a} {100 * v:.0f} %" for a, v in sorted(scaling.items()))
            warning = (f"UR speed scaling ({arms}) below min_speed_scaling {100 * minimum:.0f} "
                       "%: zero command (raise the teach pendant's speed slider, or lower "
                       "min_speed_scaling)")
        return True, began, warning
