"""A person's hand that presses on the skin with a force (pure, no rclpy).

The hand is a sphere pulled by the spring–damper of :mod:`phri_sim.world.person_body` (stiffness
K_h) to a scripted target. At rest against a surface its contact force equals the spring force, so a
target placed δ = F/K_h inside the *touching* position presses with F. A target fixed in the world
loses its force as the robot yields (measured: 15 N scripted, 0.7 N after 4 s); a person keeps
pushing. :class:`ForceHand` therefore places the target relative to the link's *current* surface::

    p_target(t) = p_s(t) + n̂(t) · (r_h + g(t) − F(t) / K_h)                       [m]

with p_s the touched skin point (moving with the link), n̂ its outward normal, r_h the hand radius,
g(t) the gap that closes before the press (:data:`GAP` → 0 over :data:`CLOSE_TIME`) and F(t) the
target normal force: a cosine rise over :data:`RISE_TIME` after the gap has closed and a cosine
release over :data:`RELEASE_TIME` from ``t_off``. The target velocity (for the damper) is the
finite difference of successive targets, so a hand on a moving link keeps its force (the damper
would otherwise brake it). After the release the hand lifts :data:`LIFT` off the surface *in the
world* (it lets go: the link coasts away from it), withdraws :data:`RETREAT` further when it has
the time (a link with stiffness K > 0 springs back towards where the hand was; along the normal,
so the hand does not sweep across the arm), and travels to its next touch along a minimum-jerk
path.

A :class:`Touch` is either fixed on the skin (axial coordinate s and angle φ on the patch) or
slides: its tangential position is then scripted in the world along the link axis of the start
state (a person moves the hand in the room; a robot that follows the hand shrinks the slide on
the skin), its depth still measured from the current surface. Every touch must land on skin: a
touch point outside the patch (by less than :data:`EDGE_MARGIN` from its end) raises
:class:`TouchOffSkinError` when the touch is built and, for a slide, whenever the hand presses.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from phri_description.description import robot_description
from phri_sim.scenarios.motion_profiles import minimum_jerk, smoothstep
from phri_sim.world.person_body import HAND_RADIUS, LEFT_HAND, RIGHT_HAND, PartTarget
from phri_sim.world.simulation import Simulation

FloatArray = NDArray[np.float64]

HAND_STIFFNESS = LEFT_HAND.stiffness
"""K_h of both hands' springs [N/m]: depth inside the touching position = F / K_h."""
assert RIGHT_HAND.stiffness == HAND_STIFFNESS
GAP = 0.03
"""Distance of the hand off the surface before and after a touch [m]."""
CLOSE_TIME = 0.25
"""Time to close the gap at ``t_on`` [s]."""
RISE_TIME = 0.3
"""Rise of the normal force once the gap is closed [s] (a person's push builds up in ~0.3 s)."""
RELEASE_TIME = 0.1
"""Fall of the normal force from ``t_off`` [s] (a hand lets go in about 0.1 s)."""
LIFT = 0.05
"""How far the hand lifts off (world frame, along the normal at release) [m]."""
LIFT_TIME = 0.4
"""Duration of the lift [s]."""
RETREAT = 0.15
"""After lifting off, a hand with time to spare withdraws this much further along the normal
(world) [m]: a link with stiffness K > 0 springs back to where it was pressed from."""
HAND_TRAVEL = 1.0
"""Time a hand takes to travel to a touch [s]; it arrives :data:`ARRIVE` before ``t_on``."""
ARRIVE = 0.25
"""The hand waits this long at the approach point before closing the gap [s]."""
EDGE_MARGIN = 0.01
"""A touch point must lie at least this far inside the patch's axial range [m]."""
MAX_DIFFERENCE_STEP = 0.05
"""Successive targets further apart in time than this get zero velocity [s]."""


class TouchOffSkinError(ValueError):
    """A scripted touch does not land on the skin patch."""


Slide = Callable[[float], float]
"""Tangential offset of a sliding touch along the link axis of the start state, at time t [m]."""


@dataclass(frozen=True)
class Touch:
    """One touch of a hand.

    Attributes:
        patch: skin patch name.
        s: axial coordinate of the touch point on the patch [m] (a slide's centre).
        phi: angle of the touch point on the patch [rad].
        t_on: the hand starts to close the gap [s].
        t_off: the normal force starts to fall [s].
        force: target normal force F [N].
        slide: tangential world offset along the start axis over time, or ``None`` (fixed).
        anchor: world point of (s, φ) at the start state [m] (used by a slide).
        axis: the link axis in the world at the start state (used by a slide).
    """

    patch: str
    s: float
    phi: float
    t_on: float
    t_off: float
    force: float
    slide: Slide | None = None
    anchor: tuple[float, float, float] = (0.0, 0.0, 0.0)
    axis: tuple[float, float, float] = (1.0, 0.0, 0.0)

    @property
    def t_lift(self) -> float:
        """The force has fallen to zero: the hand lifts off [s]."""
        return self.t_off + RELEASE_TIME

    @property
    def t_end(self) -> float:
        """The hand has lifted off [s]."""
        return self.t_lift + LIFT_TIME


def check_on_skin(patch: str, s: float, what: str) -> None:
    """Raise :class:`TouchOffSkinError` unless axial coordinate ``s`` [m] lies on ``patch`` with
    :data:`EDGE_MARGIN` to spare; ``what`` names the touch in the message."""
    lo, hi = robot_description().patch(patch).axial_range
    if not lo + EDGE_MARGIN <= s <= hi - EDGE_MARGIN:
        raise TouchOffSkinError(
            f"{what}: touch point s = {s:.4f} m is off the skin of patch {patch!r}; allowed "
            f"axial range [{lo + EDGE_MARGIN:.4f}, {hi - EDGE_MARGIN:.4f}] m")


def make_touch(sim: Simulation, patch: str, s: float, from_direction: Sequence[float],
               t_on: float, t_off: float, force: float, slide: Slide | None = None) -> Touch:
    """A touch of ``patch`` at axial coordinate ``s`` [m] by a hand coming from
    ``from_direction`` (world, link → hand) at the current robot state; checks it is on skin."""
    if not (force > 0.0 and math.isfinite(force)):
        raise ValueError(f"touch force [N] refused value {force}: allowed range (0, inf)")
    if not t_on + CLOSE_TIME + RISE_TIME <= t_off:
        raise ValueError(f"touch t_off = {t_off} s refused: allowed >= t_on + "
                         f"{CLOSE_TIME + RISE_TIME} s (t_on = {t_on} s)")
    check_on_skin(patch, s, f"touch of {patch} at t = {t_on} s")
    p = robot_description().patch(patch)
    rot, pos = sim.link_pose(p.link)
    axis, e0 = np.array(p.axis), np.array(p.zero_direction)
    u = rot.T @ (np.asarray(from_direction, dtype=float) / np.linalg.norm(from_direction))
    phi = math.atan2(float(u @ np.cross(axis, e0)), float(u @ e0))
    anchor = rot @ p.surface_point(s, phi) + pos
    world_axis = rot @ axis
    return Touch(patch, s, phi, t_on, t_off, force, slide,
                 (float(anchor[0]), float(anchor[1]), float(anchor[2])),
                 (float(world_axis[0]), float(world_axis[1]), float(world_axis[2])))


def normal_force(touch: Touch, t: float) -> float:
    """Target normal force F(t) of ``touch`` [N] (module docstring)."""
    rise = smoothstep((t - touch.t_on - CLOSE_TIME) / RISE_TIME)
    return touch.force * (rise - smoothstep((t - touch.t_off) / RELEASE_TIME))


def gap(touch: Touch, t: float) -> float:
    """Gap g(t) between the hand and the surface before the press [m]."""
    return GAP * (1.0 - smoothstep((t - touch.t_on) / CLOSE_TIME))


def touch_point(sim: Simulation, touch: Touch, t: float) -> tuple[FloatArray, FloatArray, float]:
    """(skin point p_s [m], outward normal n̂, axial coordinate s [m]) of ``touch`` at time ``t``
    at the current robot state; a slide pressing off the skin raises :class:`TouchOffSkinError`."""
    p = robot_description().patch(touch.patch)
    rot, pos = sim.link_pose(p.link)
    s = touch.s
    if touch.slide is not None:
        world = np.array(touch.anchor) + np.array(touch.axis) * touch.slide(t)
        s = float((rot.T @ (world - pos) - np.array(p.point)) @ np.array(p.axis))
        if normal_force(touch, t) > 0.0:
            check_on_skin(touch.patch, s, f"sliding touch of {touch.patch} at t = {t:.2f} s")
        lo, hi = p.axial_range
        s = min(max(s, lo), hi)
    return rot @ p.surface_point(s, touch.phi) + pos, rot @ p.normal(touch.phi), s


class ForceHand:
    """One hand's target over time for a list of touches (module docstring).

    Stateful: the point where the hand let go is frozen when the script first reaches it, so the
    script must be called with non-decreasing times (as the simulation does); same calls, same
    targets.
    """

    def __init__(self, sim: Simulation, rest: Sequence[float], touches: Sequence[Touch]) -> None:
        self.sim = sim
        self.rest = np.asarray(rest, dtype=np.float64)
        self.touches = sorted(touches, key=lambda k: k.t_on)
        for a, b in zip(self.touches, self.touches[1:], strict=False):
            if b.t_on - ARRIVE - HAND_TRAVEL < a.t_end:
                raise ValueError(f"touch at t_on = {b.t_on} s refused: the hand is still busy "
                                 f"with the touch ending at {a.t_end} s (it needs "
                                 f"{ARRIVE + HAND_TRAVEL} s to travel)")
        self._released: dict[int, tuple[FloatArray, FloatArray]] = {}
        self._last: tuple[float, FloatArray, FloatArray] | None = None

    def _pressing(self, touch: Touch, t: float) -> FloatArray:
        point, normal, _ = touch_point(self.sim, touch, t)
        depth = HAND_RADIUS + gap(touch, t) - normal_force(touch, t) / HAND_STIFFNESS
        return np.asarray(point + normal * depth)

    def _travel(self, touch: Touch, here: FloatArray, t: float, t_go: float) -> FloatArray:
        """On the way from ``here`` to the touch's approach point: first (70 % of the travel) to
        a point :data:`RETREAT` further out along the normal, rising to its height in the first
        half (a hand goes over an arm, not through it), then in along the normal."""
        point, normal, _ = touch_point(self.sim, touch, t)
        approach = point + normal * (HAND_RADIUS + GAP)
        far = approach + normal * RETREAT
        first = 0.7 * HAND_TRAVEL
        if t < t_go + first:
            x = (t - t_go) / first
            shape = np.array([minimum_jerk(x), minimum_jerk(x), minimum_jerk(min(2.0 * x, 1.0))])
            return np.asarray(here + (far - here) * shape)
        x = (t - t_go - first) / (HAND_TRAVEL - first)
        return np.asarray(far + (approach - far) * minimum_jerk(x))

    def position(self, t: float) -> FloatArray:
        """The hand's target position at time ``t`` [m] (world)."""
        here = self.rest
        for k, touch in enumerate(self.touches):
            t_arrive = touch.t_on - ARRIVE
            t_go = t_arrive - HAND_TRAVEL
            if k == 0 and t_go < 0.0:
                t_go = t_arrive = -math.inf  # starts at the touch
            if t < t_go:
                return here
            if t < t_arrive:
                return self._travel(touch, here, t, t_go)
            if t < touch.t_lift:
                return self._pressing(touch, t)
            if k not in self._released:  # let go: freeze where the hand is, in the world
                point, normal, _ = touch_point(self.sim, touch, t)
                self._released[k] = (np.asarray(point + normal * HAND_RADIUS), normal)
            start, normal = self._released[k]
            if t < touch.t_end:
                return np.asarray(start + normal * LIFT * minimum_jerk(
                    (t - touch.t_lift) / LIFT_TIME))
            here = np.asarray(start + normal * LIFT)
            if self._retreats(k):  # withdraw: the link may spring back (K > 0)
                x = minimum_jerk((t - touch.t_end) / HAND_TRAVEL)
                here = np.asarray(here + normal * RETREAT * x)
        return here

    def _retreats(self, k: int) -> bool:
        """After touch ``k`` the hand withdraws :data:`RETREAT` further along the normal when
        it has the time before it must leave for its next touch."""
        if k + 1 == len(self.touches):
            return True
        later = self.touches[k + 1]
        return later.t_on - ARRIVE - HAND_TRAVEL >= self.touches[k].t_end + HAND_TRAVEL

    def __call__(self, t: float) -> PartTarget:
        """Target position and velocity (finite difference of successive calls) at ``t``."""
        pos = self.position(t)
        vel = np.zeros(3)
        last = self._last
        if last is not None and t == last[0]:
            return PartTarget(pos, last[2])
        if last is not None and 0.0 < t - last[0] <= MAX_DIFFERENCE_STEP:
            vel = (pos - last[1]) / (t - last[0])
        self._last = (t, pos, vel)
        return PartTarget(pos, vel)
