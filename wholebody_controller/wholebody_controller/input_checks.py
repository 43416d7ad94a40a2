"""Physical-plausibility checks of the controller node's inputs (pure, no rclpy).

A decoded message can be well-formed and finite and still impossible: a contact force no skin can
report, a joint far outside its mechanical range, a base that moved half a metre between two
odometry messages. Such inputs are refused at the node's boundary as bad input (rule F9 of
:mod:`~wholebody_controller.freshness`: zero command, a clear error, recovery on the next good
message) instead of being acted on. Each check raises :class:`InputError` naming the field, the
value and the allowed range.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence


class InputError(ValueError):
    """A message the node refuses (malformed, non-finite or physically impossible)."""


def check_contact_force(link: str, force: Sequence[float], max_force: float) -> None:
    """‖ᶦf_η‖ ≤ ``max_force`` [N] (parameter ``max_contact_force``)."""
    magnitude = math.sqrt(sum(f * f for f in force))
    if not magnitude <= max_force:
        raise InputError(f"contact state of {link}: |force| = {magnitude:.6g} N is outside the "
                         f"allowed range [0, {max_force:g}] N (max_contact_force)")


def check_joint_positions(positions: Mapping[str, float],
                          limits: Mapping[str, tuple[float, float]], margin: float) -> None:
    """Every named joint within its position limits widened by ``margin`` [rad] (parameter
    ``joint_limit_margin``); names without limits are not checked."""
    for name, value in positions.items():
        bounds = limits.get(name)
        if bounds is None:
            continue
        lower, upper = bounds[0] - margin, bounds[1] + margin
        if not lower <= value <= upper:
            raise InputError(f"joint state: {name} = {value:.6g} rad is outside the allowed "
                             f"range [{lower:.6g}, {upper:.6g}] rad (limits ± joint_limit_margin)")


def check_odometry_jump(previous: Sequence[float] | None, current: Sequence[float],
                        max_jump: float) -> None:
    """The base position moved at most ``max_jump`` [m] since the previous odometry message
    (parameter ``max_odom_jump``); ``previous`` = [x, y, yaw] of the last message received,
    refused or not, so a single discontinuity costs one message, not every later one."""
    if previous is None:
        return
    jump = math.hypot(current[0] - previous[0], current[1] - previous[1])
    if not jump <= max_jump:
        raise InputError(f"odometry: the base position jumped {jump:.6g} m since the previous "
                         f"message; allowed range [0, {max_jump:g}] m (max_odom_jump)")
