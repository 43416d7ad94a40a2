"""Velocity guard between the controller's ``/cmd_vel`` and the base driver (pure, no rclpy).

* Limits: |v_x| ≤ ``max_linear_x``, |v_y| ≤ ``max_linear_y``, ‖(v_x, v_y)‖ ≤ ``max_planar_speed``
  [m/s], |ω_z| ≤ ``max_angular_z`` [rad/s]. A twist over any limit is scaled down as a whole by the
  smallest factor that satisfies them all, so the base keeps the direction the person leads it in
  (clipping axes separately would turn it).
* A twist with NaN/Inf in any component is refused: zero is sent instead.
* Components a planar base cannot follow (v_z, ω_x, ω_y) are dropped.
* No twist for ``command_timeout`` → zero (sent every check period while stale, so a driver with
  its own timeout sees a live zero stream rather than silence).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

from phri_common import paper

PlanarTwist = tuple[float, float, float]
"""(v_x [m/s], v_y [m/s], ω_z [rad/s]) in the base frame."""

ZERO: PlanarTwist = (0.0, 0.0, 0.0)


@dataclass(frozen=True)
class BaseGuardConfig:
    """Limits [m/s, rad/s] and staleness timeout [s] (ranges: ``base_guard_node.PARAMS``); the
    per-axis defaults are the paper's Table II bound (:data:`phri_common.paper.VELOCITY_LIMIT`)."""

    max_linear_x: float = paper.VELOCITY_LIMIT
    max_linear_y: float = paper.VELOCITY_LIMIT
    max_planar_speed: float = 0.2
    max_angular_z: float = paper.VELOCITY_LIMIT
    command_timeout: float = 0.1

    def __post_init__(self) -> None:
        for name in ("max_linear_x", "max_linear_y", "max_planar_speed", "max_angular_z",
                     "command_timeout"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0.0):
                raise ValueError(
                    f"base guard setting {name} refused value {value!r}: allowed [0, inf), "
                    "finite"
                )


def limit_twist(twist: PlanarTwist, config: BaseGuardConfig) -> tuple[PlanarTwist, float]:
    """Scale ``twist`` uniformly into the limits; return it and the factor applied (≤ 1)."""
    vx, vy, wz = twist
    factor = 1.0
    for value, limit in ((abs(vx), config.max_linear_x), (abs(vy), config.max_linear_y),
                         (math.hypot(vx, vy), config.max_planar_speed),
                         (abs(wz), config.max_angular_z)):
        if value > limit:
            factor = min(factor, limit / value)
    return (vx * factor, vy * factor, wz * factor), factor


@dataclass
class GuardCounters:
    """Counts since start-up (diagnostics)."""

    received: int = 0
    refused: int = 0
    limited: int = 0
    stale_zeros: int = 0
    last_refusal: str = ""


@dataclass
class BaseGuard:
    """Stateful guard: :meth:`command` on every twist, :meth:`check` on a timer."""

    config: BaseGuardConfig = field(default_factory=BaseGuardConfig)
    counters: GuardCounters = field(default_factory=GuardCounters)
    _last_stamp: float | None = None

    def command(self, twist6: Sequence[float], now: float) -> PlanarTwist:
        """The twist to send for an incoming (v_x, v_y, v_z, ω_x, ω_y, ω_z) received at ``now``."""
        self.counters.received += 1
        if len(twist6) != 6 or not all(math.isfinite(v) for v in twist6):
            self.counters.refused += 1
            self.counters.last_refusal = f"non-finite twist {list(twist6)}"
            self._last_stamp = now  # fresh, but zero: the base stops now, not after the timeout
            return ZERO
        out, factor = limit_twist((twist6[0], twist6[1], twist6[5]), self.config)
        if factor < 1.0:
            self.counters.limited += 1
        self._last_stamp = now
        return out

    def stale(self, now: float) -> bool:
        """No twist (or only an old one) as of ``now``."""
        return self._last_stamp is None or now - self._last_stamp > self.config.command_timeout

    def check(self, now: float) -> PlanarTwist | None:
        """Zero when the command stream is stale (send it), else ``None`` (nothing to send)."""
        if self.stale(now):
            self.counters.stale_zeros += 1
            return ZERO
        return None


__all__ = ["ZERO", "BaseGuard", "BaseGuardConfig", "GuardCounters", "PlanarTwist", "limit_twist"]
