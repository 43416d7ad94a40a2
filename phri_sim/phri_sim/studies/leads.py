"""Lead scenarios for the followability map: the waltz partner leads one motion (pure, no rclpy).

A :class:`Lead` is a translation of the whole partner at heading h (robot base frame at the
start; 0° = forward, +x; 90° = to the robot's left, +y) and speed v [m/s], or a turn of the couple
at ω [rad/s] (+ = left, counter-clockwise seen from above). :func:`lead_scenario` builds a
:class:`~phri_sim.scenarios.catalogue.Scenario` from the ``waltz`` scenario (its robot start,
controller and estimation parameters, settling, and its partner's hold at t = 0: every part's t = 0
target, so a changed partner or hold in ``scenarios/catalogue.py`` is picked up here) in which
every part's target moves rigidly (the lead is a scenario value of its own: nothing registers
it):

* translation: p(t) = p₀ + v·s(t)·(cos h, sin h, 0), heading unchanged;
* turn: the hold rotates by θ(t) = ω·s(t) about the vertical through the couple's centre c (the
  midpoint of the robot base origin and the partner's start, as a couple turns about its
  centre): p(t) = c + R_z(θ)(p₀ − c), yaw ψ₀ + θ;

with the speed profile s(t) (eq. L1, [s] per unit speed): standing in the hold for ``intro``,
a cosine ramp up over ``ramp``, ``cruise`` at full speed, a cosine ramp down over ``ramp``, and
standing still to the end. The spring targets' velocities are the profile's derivative, so the
partner is driven exactly along it and a robot that does not follow builds force.

Every lead covers the same amount (:class:`LeadTiming`: 0.30 m of translation or 90° of turn),
so a slow lead lasts longer, and a robot that stands still either lets the whole lead through as
drift (3× the position bar, 9× the heading bar) or blocks it and builds force, at any speed: a
pass is never a lead too small to tell.

:func:`followability_map` searches, per lead direction, increasing speeds until the first one
that fails the bars (:func:`lead_passes`); the fastest speed before it is "followed". Its tempo
axis (:func:`waltz_peaks`) puts each in units of the waltz: a lead followed at v is as fast as
the default waltz at ×v / 0.055 m/s (turns: ×ω / 0.13 rad/s), the peaks of its routine at ×1. The
search takes the function that runs one lead, so it is tested without the simulator.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from phri_sim.evaluation.following_metrics import Bars, check_bars
from phri_sim.scenarios.catalogue import SCENARIOS, Partner, Scenario, Script, with_partner
from phri_sim.scenarios.waltz_choreography import waltz_choreography
from phri_sim.world.person_body import PartTarget
from phri_sim.world.simulation import Simulation

HEADINGS_DEG: tuple[float, ...] = (0.0, 45.0, 90.0, 135.0, 180.0, 225.0, 270.0, 315.0)
"""Lead directions of the map in the robot base frame [deg]."""
SPEEDS: tuple[float, ...] = (0.025, 0.05, 0.075, 0.1, 0.15, 0.2, 0.3, 0.5)
"""Translation speeds tried, increasing [m/s] (0.5 m/s: the mecanum base's limit)."""
TURN_RATES: tuple[float, ...] = (0.05, 0.1, 0.15, 0.3, 0.5, 1.0)
"""Turn rates tried in each direction, increasing [rad/s] (1.0 rad/s: the base's limit)."""


@dataclass(frozen=True)
class Profile:
    """The lead's timing (eq. L1) [s]."""

    intro: float = 1.0
    ramp: float = 1.0
    cruise: float = 4.0
    outro: float = 1.0

    def __post_init__(self) -> None:
        for name in ("intro", "ramp", "cruise", "outro"):
            if not getattr(self, name) >= 0.0:
                raise ValueError(f"profile {name}={getattr(self, name)}: must be >= 0 s")
        if self.ramp <= 0.0:
            raise ValueError(f"profile ramp={self.ramp}: must be > 0 s")

    @property
    def duration(self) -> float:
        """Length of the lead scenario [s]."""
        return self.intro + 2.0 * self.ramp + self.cruise + self.outro

    def distance(self, t: float) -> tuple[float, float]:
        """(s(t) [s], ṡ(t) [1]): distance and speed per unit lead speed at time ``t`` (L1)."""
        r, t0 = self.ramp, self.intro
        t1 = t0 + r + self.cruise
        if t <= t0:
            return 0.0, 0.0
        if t < t0 + r:
            u = (t - t0) / r
            return r * (u / 2.0 - math.sin(math.pi * u) / (2.0 * math.pi)), _up(u)
        if t <= t1:
            return r / 2.0 + (t - t0 - r), 1.0
        if t < t1 + r:
            u = (t - t1) / r
            return (r / 2.0 + self.cruise + r * (u / 2.0 + math.sin(math.pi * u) / (2.0 * math.pi)),
                    1.0 - _up(u))
        return r + self.cruise, 0.0


def _up(u: float) -> float:
    return 0.5 - 0.5 * math.cos(math.pi * u)


@dataclass(frozen=True)
class LeadTiming:
    """How much every lead covers and its standing / ramp times.

    Attributes:
        distance: translation of a lead [m].
        angle: turn of a lead [rad].
        intro, ramp, outro: standing in the hold, the longest speed ramp, standing after [s].
    """

    distance: float = 0.30
    angle: float = 0.5 * math.pi
    intro: float = 1.0
    ramp: float = 1.0
    outro: float = 1.0

    def __post_init__(self) -> None:
        for name in ("distance", "angle", "ramp"):
            if not getattr(self, name) > 0.0:
                raise ValueError(f"lead timing {name}={getattr(self, name)}: must be > 0")

    def profile(self, lead: Lead) -> Profile:
        """The lead's profile (L1): ramps of ``ramp`` (at most half the lead's time at full
        speed), the cruise that makes it cover ``distance`` / ``angle``."""
        amount = self.distance if lead.kind == "translate" else self.angle
        at_speed = amount / abs(lead.speed)  # s(end) = ramp + cruise = amount / speed
        ramp = min(self.ramp, 0.5 * at_speed)
        return Profile(self.intro, ramp, at_speed - ramp, self.outro)


FULL_TIMING = LeadTiming()
SHORT_TIMING = LeadTiming(distance=0.15, angle=math.radians(30.0), intro=0.5, ramp=0.5,
                          outro=0.5)
"""The CI form: 0.15 m or 30° per lead (still 1.5× / 3× the drift bars)."""


@dataclass(frozen=True)
class Lead:
    """One lead: ``kind`` ``translate`` (``heading_deg`` [deg] in the base frame, ``speed``
    [m/s] > 0) or ``turn`` (``speed`` = ω [rad/s], sign = direction, + left)."""

    kind: str
    speed: float
    heading_deg: float = 0.0

    def __post_init__(self) -> None:
        if self.kind not in ("translate", "turn"):
            raise ValueError(f"lead kind {self.kind!r}: allowed 'translate' or 'turn'")
        if self.kind == "translate" and not self.speed > 0.0:
            raise ValueError(f"lead speed={self.speed}: a translation needs speed > 0 m/s")
        if self.kind == "turn" and self.speed == 0.0:
            raise ValueError("lead speed=0: a turn needs ω != 0 rad/s")

    @property
    def name(self) -> str:
        """Scenario name, e.g. ``lead_translate_045_0.100`` or ``lead_turn_+0.300``."""
        if self.kind == "translate":
            return f"lead_translate_{self.heading_deg:03.0f}_{self.speed:.3f}"
        return f"lead_turn_{self.speed:+.3f}"


def _moved(target: PartTarget, shift: np.ndarray, rot: float, centre: np.ndarray,
           velocity: np.ndarray, rate: float) -> PartTarget:
    """``target`` rotated by ``rot`` about the vertical through ``centre`` then shifted by
    ``shift`` (world) with the rigid motion's velocity (``velocity`` + ``rate`` ẑ × r)."""
    c, s = math.cos(rot), math.sin(rot)
    rz = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])

    def place(p: np.ndarray) -> np.ndarray:
        return np.asarray(centre + rz @ (p - centre) + shift)

    pos = place(target.position)
    arm = pos - centre - shift
    vel = target.velocity + velocity + rate * np.array([-arm[1], arm[0], 0.0])
    rest = None if target.rest is None else place(target.rest)
    return PartTarget(pos, vel, target.yaw + rot, rest=rest)


def lead_script(lead: Lead, profile: Profile, base: Scenario) -> Callable[[Simulation], Script]:
    """The ``make_script`` of a lead: ``base``'s partner at t = 0, moved rigidly (module
    docstring)."""
    def make(sim: Simulation) -> Script:
        hold = base.make_script(sim)(0.0)
        first = next(iter(hold.values()))
        centre = np.array([0.5 * first.position[0], 0.5 * first.position[1], 0.0])
        h = math.radians(lead.heading_deg)
        direction = np.array([math.cos(h), math.sin(h), 0.0])

        def script(t: float) -> dict[str, PartTarget]:
            dist, rate = profile.distance(t)
            if lead.kind == "translate":
                shift, vel = direction * lead.speed * dist, direction * lead.speed * rate
                return {n: _moved(p, shift, 0.0, centre, vel, 0.0) for n, p in hold.items()}
            zero = np.zeros(3)
            return {n: _moved(p, zero, lead.speed * dist, centre, zero, lead.speed * rate)
                    for n, p in hold.items()}

        return script

    return make


def lead_scenario(lead: Lead, profile: Profile, base: str = "waltz") -> Scenario:
    """A scenario in which the partner of scenario ``base`` leads ``lead`` (module docstring;
    the partner's hands parked)."""
    sc = with_partner(SCENARIOS[base], Partner(hand=False))
    return dataclasses.replace(
        sc, name=lead.name, description=f"followability lead: {lead}",
        duration=profile.duration, short_duration=profile.duration,
        make_script=lead_script(lead, profile, sc), metrics="waltz", bars="paper",
        partner={"lead": lead.name})


def lead_passes(metrics: dict[str, Any], bars: Bars) -> dict[str, bool | None]:
    """Whether one lead run stays within the bars:
    :func:`~phri_sim.evaluation.following_metrics.check_bars` on its ``following`` block, the ISO/TS
    15066 limits on every link and part, no limit violations."""
    out: dict[str, bool | None] = dict(check_bars(metrics["following"], bars))
    out["iso15066"] = bool(metrics.get("iso15066", {}).get("ok", True))
    out["no_violations"] = metrics.get("limit_violations", 0) == 0
    out["all"] = all(v is not False for k, v in out.items() if k != "all")
    return out


RunLead = Callable[[Lead], dict[str, Any]]
"""Runs one lead and returns its metrics (with a ``following`` block)."""


def _cell(lead: Lead, metrics: dict[str, Any], bars: Bars) -> dict[str, Any]:
    f = metrics["following"]
    return {"speed": lead.speed, "pass": lead_passes(metrics, bars),
            "band_share": f["band_share"], "position_drift_max": f["position_drift_max"],
            "heading_drift_max_deg": f["heading_drift_max_deg"],
            "peak_partner_force": max(f.get("peak_force", {}).get("person", {}).values(),
                                      default=0.0),
            "force_error_rms": f["force_error_rms"]}


def search(make: Callable[[float], Lead], speeds: Sequence[float], run: RunLead, bars: Bars
           ) -> dict[str, Any]:
    """Try ``speeds`` in increasing order until one fails: the cells tried and the fastest
    speed followed (0 if the slowest fails)."""
    cells: list[dict[str, Any]] = []
    fastest = 0.0
    for v in sorted(speeds):
        lead = make(v)
        cell = _cell(lead, run(lead), bars)
        cells.append(cell)
        if not cell["pass"]["all"]:
            break
        fastest = v
    return {"fastest_followed": fastest, "cells": cells}


def followability_map(run: RunLead, bars: Bars, headings: Sequence[float] = HEADINGS_DEG,
                      speeds: Sequence[float] = SPEEDS,
                      turn_rates: Sequence[float] = TURN_RATES) -> dict[str, Any]:
    """The map (module docstring): per heading and per turn direction the fastest lead
    followed [m/s, rad/s] and every cell tried."""
    def translation(h: float) -> Callable[[float], Lead]:
        return lambda v: Lead("translate", v, h)

    def turning(sign: float) -> Callable[[float], Lead]:
        return lambda w: Lead("turn", sign * w)

    speed, rate = waltz_peaks()
    translate = [{"heading_deg": h, **search(translation(h), speeds, run, bars)}
                 for h in headings]
    turn = [{"direction": side, **search(turning(sign), turn_rates, run, bars)}
            for side, sign in (("left", 1.0), ("right", -1.0))]
    for row in translate:
        row["fastest_tempo_scale"] = row["fastest_followed"] / speed
    for row in turn:
        row["fastest_tempo_scale"] = row["fastest_followed"] / rate
    return {"bars": dataclasses.asdict(bars), "translate": translate, "turn": turn,
            "tempo_axis": {"peak_speed": speed, "peak_turn_rate": rate}}


def waltz_peaks(tempo: str = "paper") -> tuple[float, float]:
    """(peak planar speed [m/s], peak turn rate [rad/s]) of the waltz routine at ``tempo``, ×1:
    the map's tempo axis (a lead followed at speed v is as fast as the waltz at ×v / peak)."""
    chor = waltz_choreography(tempo, 0.0, 0.0)
    ts = np.linspace(0.0, chor.duration, 20001)
    poses = [chor.pose(float(t)) for t in ts]
    return (max(float(np.linalg.norm(p[2])) for p in poses),
            max(abs(p[3]) for p in poses))
