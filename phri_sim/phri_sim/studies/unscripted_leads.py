"""Unscripted leads: figures the waltz does not script, led from the waltz's hold (pure, no rclpy).

The robot was measured failing every turn in place or about a pivot, losing the hold to a
partner backing away at 0.1 m/s and failing a quick 0.3 m box. Each
:class:`UnscriptedLead` is a sequence of :class:`Leg` s that move the whole partner rigidly
(every part's t = 0 target of the ``waltz`` hold, the hands parked), each leg with the speed
profile (L1) of :class:`~phri_sim.studies.leads.Profile` (cosine ramps, full speed between):

* ``translate``: along a heading of the robot's start frame (0° forward, 90° into the left
  forearm, 270° away from it) by ``amount`` [m] at ``speed`` [m/s];
* ``turn``: about the vertical through the *pivot*, a point ``pivot`` of the way from the robot
  base's start to the partner's (0: the robot's centre, 0.5: the couple's centre, 1: the partner
  turning in place), carried along by the legs before it, by ``amount`` [rad] at ``speed``
  [rad/s] (sign = direction, + left).

The rigid motion after leg k is p ↦ R(θ_k) p + d_k; a turn about c by φ maps it to
R(φ + θ_k) p + c + R(φ)(d_k − c). :data:`UNSCRIPTED_LEADS` holds these figures; each is
a scenario (:func:`unscripted_scenario`) judged by the default waltz's bars, every lead ending
with the partner standing still (the time-to-rest bar).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from phri_sim.scenarios.catalogue import SCENARIOS, Partner, Scenario, Script, with_partner
from phri_sim.studies.leads import Profile
from phri_sim.world.person_body import PartTarget
from phri_sim.world.simulation import Simulation

FloatArray = np.ndarray


@dataclass(frozen=True)
class Leg:
    """One rigid motion of the partner (module docstring).

    Attributes:
        kind: ``translate`` or ``turn``.
        speed: full speed [m/s] (> 0) or turn rate [rad/s] (≠ 0, + left).
        amount: distance [m] or angle [rad] covered (> 0).
        heading_deg: direction of a translation in the robot's start frame [deg].
        pivot: where a turn's axis lies, from the robot base (0) to the partner (1) [1].
        ramp: longest speed ramp [s] (at most half the leg's time at full speed).
    """

    kind: str
    speed: float
    amount: float
    heading_deg: float = 0.0
    pivot: float = 0.5
    ramp: float = 0.5

    def __post_init__(self) -> None:
        if self.kind not in ("translate", "turn"):
            raise ValueError(f"leg kind {self.kind!r}: allowed 'translate' or 'turn'")
        if not (self.amount > 0.0 and self.ramp > 0.0 and self.speed != 0.0):
            raise ValueError(f"leg amount {self.amount}, ramp {self.ramp} must be > 0 and "
                             f"speed {self.speed} != 0")
        if self.kind == "translate" and self.speed < 0.0:
            raise ValueError(f"leg speed {self.speed}: a translation needs speed > 0 m/s")

    def profile(self) -> Profile:
        """The leg's speed profile (L1), without standing before or after it."""
        at_speed = self.amount / abs(self.speed)
        ramp = min(self.ramp, 0.5 * at_speed)
        return Profile(0.0, ramp, at_speed - ramp, 0.0)


@dataclass(frozen=True)
class UnscriptedLead:
    """A named figure: ``legs`` one after the other, with ``intro`` standing in the hold before,
    ``pause`` standing between legs and ``outro`` standing after [s]."""

    name: str
    description: str
    legs: tuple[Leg, ...]
    intro: float = 1.0
    pause: float = 0.3
    outro: float = 3.0

    @property
    def duration(self) -> float:
        """The scenario's length [s]."""
        moving = sum(leg.profile().duration for leg in self.legs)
        return self.intro + moving + self.pause * (len(self.legs) - 1) + self.outro


def _rot(angle: float) -> FloatArray:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


@dataclass(frozen=True)
class _Pose:
    """A rigid motion p ↦ R(θ) p + d of the hold, and its rates (ω [rad/s] about ``centre``,
    ``velocity`` [m/s] of a translation)."""

    theta: float = 0.0
    shift: FloatArray = dataclasses.field(default_factory=lambda: np.zeros(3))
    rate: float = 0.0
    centre: FloatArray = dataclasses.field(default_factory=lambda: np.zeros(3))
    velocity: FloatArray = dataclasses.field(default_factory=lambda: np.zeros(3))

    def place(self, p: FloatArray) -> FloatArray:
        return np.asarray(_rot(self.theta) @ p + self.shift)

    def moved(self, target: PartTarget) -> PartTarget:
        pos = self.place(target.position)
        arm = pos - self.centre
        vel = self.velocity + self.rate * np.array([-arm[1], arm[0], 0.0])
        rest = None if target.rest is None else self.place(target.rest)
        return PartTarget(pos, _rot(self.theta) @ target.velocity + vel,
                          target.yaw + self.theta, rest=rest)


def _after(pose: _Pose, leg: Leg, s: float, rate: float, pivot0: FloatArray) -> _Pose:
    """The hold's motion ``s`` [s per unit speed] into ``leg`` (profile rate ``rate``) from
    ``pose`` at its start; ``pivot0`` = the pivot at t = 0 for ``leg.pivot``."""
    if leg.kind == "translate":
        h = math.radians(leg.heading_deg)
        direction = np.array([math.cos(h), math.sin(h), 0.0])
        return _Pose(pose.theta, pose.shift + direction * leg.speed * s,
                     velocity=direction * leg.speed * rate)
    centre = pose.place(pivot0)
    phi = leg.speed * s
    shift = centre + _rot(phi) @ (pose.shift - centre)
    return _Pose(pose.theta + phi, shift, rate=leg.speed * rate, centre=centre)


def unscripted_script(lead: UnscriptedLead, base: Scenario) -> Callable[[Simulation], Script]:
    """The ``make_script`` of ``lead``: ``base``'s hold at t = 0, moved (module docstring)."""
    def make(sim: Simulation) -> Script:
        hold = base.make_script(sim)(0.0)
        base_origin = np.array([float(sim.q[0]), float(sim.q[1]), 0.0])
        partner0 = next(iter(hold.values())).position * np.array([1.0, 1.0, 0.0])
        starts, poses = [], [_Pose()]
        t = lead.intro
        for leg in lead.legs:
            starts.append(t)
            prof = leg.profile()
            pivot = base_origin + leg.pivot * (partner0 - base_origin)
            poses.append(_after(poses[-1], leg, prof.distance(prof.duration)[0], 0.0, pivot))
            t += prof.duration + lead.pause

        def script(t: float) -> dict[str, PartTarget]:
            pose = poses[0]
            for k, (leg, t0) in enumerate(zip(lead.legs, starts, strict=True)):
                if t < t0:
                    break
                prof = leg.profile()
                pose = poses[k + 1]
                if t < t0 + prof.duration:
                    s, rate = prof.distance(t - t0)
                    pivot = base_origin + leg.pivot * (partner0 - base_origin)
                    pose = _after(poses[k], leg, s, rate, pivot)
                    break
            return {name: pose.moved(target) for name, target in hold.items()}

        return script

    return make


def unscripted_scenario(lead: UnscriptedLead, base: str | Scenario = "waltz") -> Scenario:
    """The scenario of ``lead`` from the hold of the waltz scenario ``base`` (a name of the
    catalogue or a value, e.g. with a parameter file's values; its controller parameters; the
    partner's hands parked), judged by the default waltz's bars."""
    sc = with_partner(SCENARIOS[base] if isinstance(base, str) else base, Partner(hand=False))
    return dataclasses.replace(
        sc, name=f"lead_{lead.name}", description=lead.description, duration=lead.duration,
        short_duration=lead.duration, make_script=unscripted_script(lead, sc), bars="waltz",
        partner={"lead": lead.name})


def _turn(name: str, what: str, rate: float, angle_deg: float, pivot: float) -> UnscriptedLead:
    return UnscriptedLead(name, f"{what} {angle_deg:g}° at {abs(rate):g} rad/s "
                          f"({'left' if rate > 0 else 'right'})",
                          (Leg("turn", rate, math.radians(angle_deg), pivot=pivot),))


UNSCRIPTED_LEADS: dict[str, UnscriptedLead] = {lead.name: lead for lead in (
    _turn("spin_left", "the partner turns in place", 0.5, 180.0, 1.0),
    _turn("spin_right", "the partner turns in place", -0.5, 180.0, 1.0),
    _turn("pivot_slow", "the couple turns about its centre", 0.25, 90.0, 0.5),
    _turn("pivot_fast", "the couple turns about its centre", -1.0, 180.0, 0.5),
    UnscriptedLead("back_away", "the partner backs away from the robot: 0.5 m away from the "
                   "forearm (robot frame 270°) at 0.1 m/s",
                   (Leg("translate", 0.1, 0.5, heading_deg=270.0),)),
    UnscriptedLead("box", "a quick 0.3 m box at 0.15 m/s: forward, left (into the forearm), "
                   "back, right (away from it)",
                   tuple(Leg("translate", 0.15, 0.3, heading_deg=h)
                         for h in (0.0, 90.0, 180.0, 270.0))),
)}
"""The unscripted leads: spins in place (0.5 rad/s, 180° each way), couple turns
about the couple's centre (0.25 rad/s left by 90°, 1 rad/s right by 180°), backing away (0.5 m
at 0.1 m/s) and a quick 0.3 m box (0.15 m/s)."""
