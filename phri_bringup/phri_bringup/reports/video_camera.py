"""A camera that frames the couple and turns with it, smoothed (pure: numpy only).

The target view (:func:`couple_view`) looks at the midpoint between the robot base and the
partner's torso, from the side of the couple: the horizontal viewing direction is the couple
axis (robot → partner) turned by ``side_angle``, so when the couple turns, the camera orbits with
it and the floor marks sweep past. The distance grows with the couple's separation so both stay
in frame.

:class:`SmoothCamera` filters that target with two cascaded first-order lags per coordinate
(time constant ``tau``/2 each, a critically damped second-order response: no overshoot, a
continuous camera velocity, jitter faster than ``tau`` attenuated by ≈ (2π f τ/2)²). Azimuth
differences are wrapped to (−180°, 180°] before filtering, so a target crossing ±180° turns the
camera the short way.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class View:
    """A MuJoCo free camera: look-at point [m], azimuth and elevation [deg], distance [m]."""

    lookat: FloatArray
    azimuth: float
    elevation: float
    distance: float


@dataclass(frozen=True)
class CameraRig:
    """How the camera frames the couple.

    Attributes:
        side_angle: horizontal angle between the couple axis (robot → partner) and the viewing
            direction [deg]; ±90 = side on (− = from the robot's left, where the waltz's
            waist hold is), 0 = from behind the robot.
        elevation: camera elevation [deg] (negative = looking down).
        distance: camera distance at :attr:`separation` between robot and partner [m].
        separation: nominal robot–partner distance [m]; the distance grows 1:1 beyond it.
        height: height of the look-at point [m].
        tau: smoothing time constant [s].
    """

    side_angle: float = -60.0
    elevation: float = -28.0
    distance: float = 3.4
    separation: float = 0.8
    height: float = 1.0
    tau: float = 1.5


def couple_view(robot_xy: FloatArray, partner_xy: FloatArray | None, robot_yaw: float,
                rig: CameraRig = CameraRig()) -> View:
    """Target view of the robot base at ``robot_xy`` [m] heading ``robot_yaw`` [rad] and the
    partner's torso at ``partner_xy`` [m] (``None``: no partner, look ahead of the robot)."""
    robot_xy = np.asarray(robot_xy, dtype=float)
    ahead = robot_xy + rig.separation * np.array([math.cos(robot_yaw), math.sin(robot_yaw)])
    partner = ahead if partner_xy is None else np.asarray(partner_xy, dtype=float)
    axis = partner - robot_xy
    sep = float(np.linalg.norm(axis))
    heading = math.atan2(axis[1], axis[0]) if sep > 1e-6 else robot_yaw
    mid = 0.5 * (robot_xy + partner)
    return View(np.array([mid[0], mid[1], rig.height]), math.degrees(heading) + rig.side_angle,
                rig.elevation, rig.distance + max(sep - rig.separation, 0.0))


def wrap_degrees(angle: float) -> float:
    """``angle`` wrapped into (−180, 180] [deg]."""
    return -((-angle + 180.0) % 360.0 - 180.0)


class SmoothCamera:
    """Critically damped smoothing of a stream of target :class:`View` s (module docstring)."""

    def __init__(self, tau: float = CameraRig().tau) -> None:
        if not tau > 0.0:
            raise ValueError(f"tau = {tau} s: the smoothing time constant must be > 0")
        self.tau = tau
        self._stages: list[FloatArray] | None = None

    def update(self, target: View, dt: float) -> View:
        """Advance by ``dt`` [s] towards ``target``; return the smoothed view (the first call
        returns ``target`` itself: the video starts framed)."""
        x = np.array([*target.lookat, target.azimuth, target.elevation, target.distance])
        if self._stages is None:
            self._stages = [x.copy(), x.copy()]
        else:
            alpha = 1.0 - math.exp(-max(dt, 0.0) / (0.5 * self.tau))
            s1, s2 = self._stages
            x[3] = s1[3] + wrap_degrees(x[3] - s1[3])  # the short way round
            s1 += alpha * (x - s1)
            s2[3] = s1[3] + wrap_degrees(s2[3] - s1[3])
            s2 += alpha * (s1 - s2)
        out = self._stages[1]
        return View(out[:3].copy(), float(out[3]), float(out[4]), float(out[5]))
