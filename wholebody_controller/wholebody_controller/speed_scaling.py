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
