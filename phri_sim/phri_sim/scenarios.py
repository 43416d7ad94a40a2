"""The paper's four experiments (Sec. VI, design §6) as scripted scenarios (pure, no rclpy).

A :class:`Scenario` bundles what one experiment needs: the robot's start configuration, the
controller parameters of the paper for that experiment (:attr:`Scenario.controller_parameters`,
plain names and values, built from :mod:`phri_common.paper`; the bringup passes them as ROS
parameters and generates ``phri_bringup/config/*.yaml`` from them), its length (and a shortened CI
length), and a script that moves the person's spring targets over time. Scripts are functions
of simulation time (the sliding hand also reads the robot's current link pose, as a person
pressing follows the arm), so a scenario is deterministic for a seed (the seed drives only the
skin noise).

Scenarios (``SCENARIOS``):

* ``centring`` (Fig. 6): one hand presses evenly on the middle of the right forearm, lets go,
  then two hands press the same link on opposite sides at both ends (a torque about the centre).
  Λ = 0.5 I, D = 40 I, K = 0; torque limit τ(2) ≤ 1.2 (contact estimation).
* ``sliding`` (Fig. 7): a hand presses the middle of the left forearm mostly along the link's
  normal and slides forward and back along the link. Λ = 0.5 I, D = diag(40, 40, 500, 40, 40, 40),
  K = 0; desired-region margin 0.01 m.
* ``whole_body`` (Fig. 8): periodic touches on the three skin links in turn.
  Λ = 0.5 I, D = 60 I, K = 40 I.
* ``waltz`` (Fig. 1, Sec. VI-B): from a hold resting at the 10 N preload (settled before t = 0),
  the torso walks two waltz boxes (forward, side, close, back, side, close; minimum-jerk steps),
  the second turned by 90°, a minute in all; the robot follows through its left forearm on the
  (soft) waist alone: arms held within ±0.1 rad of q_dance (:data:`Q_DANCE`, the wrist turned
  outward), left-forearm priority locked at 1, desired force 10 N to the right (base frame).
  Λ = 0.1 I, D = 200 I, K = 0.

Hands never jump between presses (:func:`hand_schedule`); the sliding hand keeps its press depth
on the link's current surface.

Table II values (q̇ ∈ [−0.15, 0.15], k_η = 200, b = 4, K_p = 5, ψ_thr = 1e-4, ε = 0.1, h = 0.15,
100 Hz) are the controller's defaults and are repeated in every parameter set for clarity. Every
value comes from :mod:`phri_common.paper`, the skin links from the robot description.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import partial
from typing import Any

import numpy as np
from numpy.typing import NDArray

from phri_common import paper
from phri_description.description import SKIN_LINKS, robot_description
from phri_sim.choreography import waltz_choreography
from phri_sim.person import HAND_RADIUS, TORSO, WAIST_RADIUS, PartTarget
from phri_sim.sim import Simulation

FloatArray = NDArray[np.float64]
Script = Callable[[float], dict[str, PartTarget]]

Q_LEFT_HOME: tuple[float, ...] = (0.0, -0.3, 0.3, 0.0, 0.0, 0.0)
"""Left arm start (and the waltz's q_dance): upper arm turned out, forearm parallel to the base
x axis at 1.06 m, elbow bent (away from the straight-arm singularity) [rad]."""
Q_RIGHT_HOME: tuple[float, ...] = (0.0, 0.3, -0.3, 0.0, 0.0, 0.0)
"""Right arm start (and q_dance), the left arm's counterpart [rad]."""
Q_HOME: tuple[float, ...] = (0.0, 0.0, 0.0, *Q_LEFT_HOME, *Q_RIGHT_HOME)
"""Start configuration q (15): base at the origin, arms at home."""

TABLE_II: dict[str, Any] = {
    "velocity_limit": paper.VELOCITY_LIMIT,
    "k_eta": paper.K_ETA,
    "b": paper.B,
    "k_p": paper.K_P,
    "psi_thr": paper.PSI_THR,
    "epsilon": paper.EPSILON,
    "horizon": paper.HORIZON,
    "rate_hz": paper.CONTROL_RATE_HZ,
}
"""The paper's Table II and Sec. VI settings (controller parameter names)."""


def _admittance(gains: paper.Admittance) -> dict[str, Any]:
    """The controller's per-link admittance parameters: ``gains`` on every skin link."""
    out: dict[str, Any] = {}
    for link in SKIN_LINKS:
        out[f"{link}.inertia"] = list(gains.inertia)
        out[f"{link}.damping"] = list(gains.damping)
        out[f"{link}.stiffness"] = list(gains.stiffness)
    return out


@dataclass(frozen=True)
class Scenario:
    """One experiment.

    Attributes:
        name: scenario name.
        description: one line for listings.
        duration: full length [s].
        short_duration: length for CI runs [s] (still covers the key events).
        q0: robot start configuration (15) [m, rad].
        controller_parameters: wholebody_controller parameters of the paper for this experiment.
        estimation_parameters: contact_estimation parameters.
        make_script: builds the person's script from the simulation at its start state.
        metrics: which metrics apply (``centring``, ``tracking``, ``whole_body``, ``waltz``).
        settle: physics settling time before t = 0 with the robot held still, so contacts the
            script starts with are at rest (:meth:`Simulation.settle`) [s].
    """

    name: str
    description: str
    duration: float
    short_duration: float
    q0: tuple[float, ...]
    controller_parameters: dict[str, Any]
    make_script: Callable[[Simulation], Script]
    metrics: str
    estimation_parameters: dict[str, Any] = field(default_factory=dict)
    settle: float = 0.0


def start_scenario(sim: Simulation, scenario: Scenario) -> Script:
    """Put ``sim`` at the start of ``scenario`` and return its person script: robot at
    ``q0``, every part at its t = 0 target at rest, then :attr:`Scenario.settle` seconds of
    settling (time reset to 0)."""
    q0 = np.array(scenario.q0)
    sim.reset(q0)
    script = scenario.make_script(sim)
    for part, target in script(0.0).items():
        sim.set_target(part, target, teleport=True)
    sim.reset(q0)
    if scenario.settle > 0.0:
        sim.settle(scenario.settle)
    return script


# ---------------------------------------------------------------------------------------------
# Geometry helpers: where on a patch a hand presses.
# ---------------------------------------------------------------------------------------------


def press_geometry(
    sim: Simulation, patch: str, s: float, from_direction: FloatArray
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """(surface point [m], outward normal, link axis) in the world where a hand coming from
    ``from_direction`` (world, pointing from the link to the hand) meets ``patch`` at axial
    coordinate ``s`` [m] (in the patch's axial range), at the current robot state."""
    p = robot_description().patch(patch)
    rot, pos = sim.link_pose(p.link)
    axis = np.array(p.axis)
    e0 = np.array(p.zero_direction)
    e1 = np.cross(axis, e0)
    u = rot.T @ (from_direction / np.linalg.norm(from_direction))
    phi = math.atan2(float(u @ e1), float(u @ e0))
    point = rot @ p.surface_point(s, phi) + pos
    normal = rot @ p.normal(phi)
    return point, normal, rot @ axis


def smoothstep(x: float) -> float:
    """0 → 1 cosine ramp on x ∈ [0, 1] (clamped), zero slope at both ends."""
    x = min(max(x, 0.0), 1.0)
    return 0.5 - 0.5 * math.cos(math.pi * x)


def smoothstep_rate(x: float, duration: float) -> float:
    """d/dt of :func:`smoothstep` (x = t / duration) [1/s]."""
    if not 0.0 < x < 1.0:
        return 0.0
    return 0.5 * math.pi * math.sin(math.pi * x) / duration


HAND_STIFFNESS = 400.0
"""Must match :data:`phri_sim.person.LEFT_HAND`'s spring [N/m]: depth = force / stiffness."""


def _hand_press(
    point: FloatArray, normal: FloatArray, force: float, amount: float
) -> FloatArray:
    """Hand target for a press of ``force`` [N] scaled by ``amount`` ∈ [0, 1]: from 3 cm off the
    surface (amount 0) to ``force / K`` inside the touching position (amount 1)."""
    touching = point + normal * HAND_RADIUS
    approach = touching + normal * 0.03
    pressed = touching - normal * (force / HAND_STIFFNESS)
    return np.asarray(approach + (pressed - approach) * amount)


def _parked(part: str, sim: Simulation) -> PartTarget:
    spec = next(p for p in sim.parts if p.name == part)
    return PartTarget(np.array(spec.parking), np.zeros(3))


def _press_target(point: FloatArray, normal: FloatArray, force: float, t: float,
                  t_on: float, t_off: float, ramp: float = 0.5) -> PartTarget:
    """A press that ramps in at ``t_on`` and out at ``t_off`` (ramp length ``ramp`` [s])."""
    amount = smoothstep((t - t_on) / ramp) - smoothstep((t - t_off) / ramp)
    rate = smoothstep_rate((t - t_on) / ramp, ramp) - smoothstep_rate((t - t_off) / ramp, ramp)
    pos = _hand_press(point, normal, force, amount)
    vel = -normal * (0.03 + force / HAND_STIFFNESS) * rate
    return PartTarget(pos, vel)


@dataclass(frozen=True)
class Press:
    """One press of a hand: ramps in at ``t_on``, out at ``t_off`` [s], on the surface point
    ``point`` with outward ``normal`` (world), with ``force`` [N]."""

    t_on: float
    t_off: float
    point: FloatArray
    normal: FloatArray
    force: float


HAND_TRAVEL = 1.5
"""Time a hand takes to move between two presses (minimum-jerk path between their approach
points, or from where it waits) [s]; it arrives 0.25 s before the press ramps in."""


def _approach(press: Press) -> FloatArray:
    return np.asarray(press.point + press.normal * (HAND_RADIUS + 0.03))


def hand_schedule(rest: FloatArray, presses: list[Press]) -> Callable[[float], PartTarget]:
    """A hand's target over time: it waits at ``rest`` (world [m]), travels to each press's
    approach point (3 cm off the surface) along a minimum-jerk path in :data:`HAND_TRAVEL`,
    presses, lifts back to the approach point and waits there for its next press. A hand whose
    first press starts too early to travel starts at that press's approach point. So a hand
    never jumps: a spring target that leaps across the scene would throw the hand at the robot.
    """
    order = sorted(presses, key=lambda p: p.t_on)
    zero = np.zeros(3)

    def target(t: float) -> PartTarget:
        here = np.asarray(rest, dtype=np.float64)
        for k, press in enumerate(order):
            approach = _approach(press)
            t_go = press.t_on - 0.25 - HAND_TRAVEL
            if t_go < 0.0 and k == 0:
                here = approach
            if t < t_go:
                return PartTarget(here, zero)
            if t < press.t_on - 0.25:
                x = (t - t_go) / HAND_TRAVEL
                delta = approach - here
                return PartTarget(here + delta * minimum_jerk(x),
                                  delta * minimum_jerk_rate(x, HAND_TRAVEL))
            later = order[k + 1] if k + 1 < len(order) else None
            if later is None or t < later.t_on - 0.25 - HAND_TRAVEL:
                return _press_target(press.point, press.normal, press.force, t, press.t_on,
                                     press.t_off)
            here = approach
        return PartTarget(here, zero)

    return target


def minimum_jerk(x: float) -> float:
    """0 → 1 minimum-jerk profile 10x³ − 15x⁴ + 6x⁵ on x ∈ [0, 1] (clamped): zero velocity and
    acceleration at both ends, as a person moves a hand or the body between two poses."""
    x = min(max(x, 0.0), 1.0)
    return x * x * x * (10.0 + x * (-15.0 + 6.0 * x))


def minimum_jerk_rate(x: float, duration: float) -> float:
    """d/dt of :func:`minimum_jerk` (x = t / duration) [1/s]."""
    if not 0.0 < x < 1.0:
        return 0.0
    return 30.0 * x * x * (1.0 - x) * (1.0 - x) / duration


# ---------------------------------------------------------------------------------------------
# 1. Contact centring (Fig. 6)
# ---------------------------------------------------------------------------------------------

CENTRING_FORCE = 15.0
"""Force of each press [N]."""


def centring_script(sim: Simulation) -> Script:
    """Even press on the middle of the right forearm (1–4 s), release; then presses from above
    near the elbow end (right hand) and from below near the wrist end (left hand, coming from
    where it waits) (6–9 s), release."""
    up = np.array([0.0, 0.0, 1.0])
    mid, n_mid, _ = press_geometry(sim, "right_forearm", 0.18, up)
    top, n_top, _ = press_geometry(sim, "right_forearm", 0.25, up)
    bottom, n_bottom, _ = press_geometry(sim, "right_forearm", 0.11, -up)
    park_t = _parked("person_torso", sim)
    f = CENTRING_FORCE
    right = hand_schedule(_parked("person_right_hand", sim).position,
                          [Press(1.0, 4.0, mid, n_mid, f), Press(6.0, 9.0, top, n_top, f)])
    left = hand_schedule(_parked("person_left_hand", sim).position,
                         [Press(6.0, 9.0, bottom, n_bottom, f)])

    def script(t: float) -> dict[str, PartTarget]:
        return {"person_right_hand": right(t), "person_left_hand": left(t),
                "person_torso": park_t}

    return script


# ---------------------------------------------------------------------------------------------
# 2. Contact-change tracking (Fig. 7)
# ---------------------------------------------------------------------------------------------

SLIDE_FORCE = 12.0
SLIDE_AMPLITUDE = 0.05
SLIDE_PERIOD = 6.0
SLIDE_RELEASE = 14.0
"""The hand lets go at this time [s] (2 s before the end of the full run)."""


def surface_shift(sim: Simulation, patch: str, point: FloatArray, normal: FloatArray) -> float:
    """How far the patch's surface under ``point`` (world) has moved along ``normal`` from
    ``point`` at the current robot state [m]: the top of the link now lies at
    ``point + shift · normal``. ``point`` is a surface point of an earlier state."""
    p = robot_description().patch(patch)
    rot, pos = sim.link_pose(p.link)
    s = float((rot.T @ (point - pos) - np.array(p.point)) @ np.array(p.axis))
    lo, hi = p.axial_range
    now, _, _ = press_geometry(sim, patch, min(max(s, lo), hi), normal)
    return float((now - point) @ normal)


def sliding_script(sim: Simulation) -> Script:
    """Press the middle of the left forearm from above (0.5–1.5 s), then slide ± 5 cm along the
    link (sinusoid in the world, 6 s period, amplitude ramped in over the first period), then
    let go at :data:`SLIDE_RELEASE`.

    The hand keeps its press depth relative to the link's current surface (a person pressing
    keeps the force, Fig. 7: the operator's force stays on while the contact slides): its
    target along the press normal follows the link as the robot yields, while the slide is
    scripted in the world, so the robot following the hand shrinks the slide on the skin."""
    up = np.array([0.0, 0.0, 1.0])
    mid, normal, axis = press_geometry(sim, "left_forearm", 0.18, up)
    park_r = _parked("person_right_hand", sim)
    park_t = _parked("person_torso", sim)

    def script(t: float) -> dict[str, PartTarget]:
        slide_t = max(t - 2.0, 0.0)
        env = smoothstep(slide_t / SLIDE_PERIOD)
        w = 2.0 * math.pi / SLIDE_PERIOD
        offset = SLIDE_AMPLITUDE * env * math.sin(w * slide_t)
        rate = SLIDE_AMPLITUDE * env * w * math.cos(w * slide_t) if t > 2.0 else 0.0
        over = mid + axis * offset
        surface = over + normal * surface_shift(sim, "left_forearm", over, normal)
        press = _press_target(surface, normal, SLIDE_FORCE, t, 0.5, SLIDE_RELEASE)
        return {
            "person_left_hand": PartTarget(press.position, press.velocity + axis * rate),
            "person_right_hand": park_r,
            "person_torso": park_t,
        }

    return script


# ---------------------------------------------------------------------------------------------
# 3. Whole-body pHRI (Fig. 8)
# ---------------------------------------------------------------------------------------------

TOUCH_FORCE = 15.0
TOUCH_PERIOD = 4.0
SCENARIO_WHOLE_BODY_LENGTH = 24.0
"""Full length of the whole-body scenario [s]."""
"""Each link is touched for 2 s of every 4 s slot, links in turn."""


def whole_body_script(sim: Simulation) -> Script:
    """The left hand touches the left upper arm and the left forearm (from the outside, +y), the
    right hand the right forearm (from above), one link per 4 s slot in turn (each touch 2 s,
    from 0.5 s into its slot); between touches a hand waits at its last approach point and
    travels to the next (:func:`hand_schedule`)."""
    side = np.array([0.0, 1.0, 0.0])
    up = np.array([0.0, 0.0, 1.0])
    spots = [
        ("person_left_hand", *press_geometry(sim, "left_upper_arm", 0.24, side)[:2]),
        ("person_left_hand", *press_geometry(sim, "left_forearm", 0.18, side)[:2]),
        ("person_right_hand", *press_geometry(sim, "right_forearm", 0.18, up)[:2]),
    ]
    slots = math.ceil(SCENARIO_WHOLE_BODY_LENGTH / TOUCH_PERIOD)
    presses: dict[str, list[Press]] = {"person_left_hand": [], "person_right_hand": []}
    for slot in range(slots):
        hand, point, normal = spots[slot % len(spots)]
        t_on = slot * TOUCH_PERIOD + 0.5
        presses[hand].append(Press(t_on, t_on + 2.0, point, normal, TOUCH_FORCE))
    hands = {name: hand_schedule(_parked(name, sim).position, p) for name, p in presses.items()}
    park_t = _parked("person_torso", sim)

    def script(t: float) -> dict[str, PartTarget]:
        out = {name: hand(t) for name, hand in hands.items()}
        out["person_torso"] = park_t
        return out

    return script


# ---------------------------------------------------------------------------------------------
# 4. Waltz (Fig. 1, Sec. VI-B)
# ---------------------------------------------------------------------------------------------

Q_DANCE_LEFT: tuple[float, ...] = (0.0, -0.3, 0.3, math.pi, 0.0, 0.0)
"""Left arm of q_dance: the home arm with the wrist turned outward (wrist 1 at π), so the forearm
embraces the waist with nothing below or inside it — with the home wrist (hanging inward) the
waist would run into the wrist as soon as it moved forward along the forearm [rad]."""
Q_DANCE: tuple[float, ...] = (*Q_DANCE_LEFT, *Q_RIGHT_HOME)
"""q_dance (12): the waltz's arm configuration, left then right arm [rad]."""
Q_WALTZ: tuple[float, ...] = (0.0, 0.0, 0.0, *Q_DANCE)
"""Waltz start configuration (15)."""

WALTZ_FORCE = paper.WALTZ_DESIRED_FORCE
"""The left forearm's desired force towards the waist (to the right in the base frame) [N]."""
WALTZ_LINK = robot_description().patch("left_forearm").link
"""The link that leads the waltz on the waist (VI-B: the left forearm)."""
WALTZ_INTRO = 2.0
"""Standing still in the hold before the first step [s]."""
WALTZ_OUTRO = 3.0
"""Standing still after the last step [s]."""
WALTZ_SETTLE = 2.0
"""Physics settling before t = 0: the hold starts resting at the 10 N preload, not with an
impact [s]."""
WALTZ_CONTACT_S = 0.18
"""Axial position of the waist contact on the left forearm patch [m] (its middle)."""
WALTZ_START_YAW = -0.5 * math.pi
"""The dancer's heading at the start (world): facing −y, away from the robot's left forearm,
which lies across the back of the waist (Fig. 1) [rad]."""


def waltz_contact(sim: Simulation) -> tuple[FloatArray, FloatArray]:
    """(waist centre [m], unit vector from the waist into the left forearm) when the waist's back
    just touches the inner (−y) side of the left forearm's middle, at the current robot state."""
    point, normal, _ = press_geometry(sim, "left_forearm", WALTZ_CONTACT_S,
                                      np.array([0.0, -1.0, 0.0]))
    centre = point + normal * WAIST_RADIUS
    return np.asarray(centre), np.asarray(-normal)


def waltz_start(sim: Simulation) -> FloatArray:
    """Torso start position [m]: the waist touching the forearm, its tissue compressed by the
    preload (:func:`waltz_contact`)."""
    centre, inward = waltz_contact(sim)
    assert TORSO.tissue is not None
    return np.asarray(centre + inward * (WALTZ_FORCE / TORSO.tissue.stiffness))


def waltz_script(sim: Simulation, tempo: str = "paper") -> Script:
    """The torso dances :func:`~phri_sim.choreography.waltz_choreography` at ``tempo`` from
    :func:`waltz_start` (heading :data:`WALTZ_START_YAW`), its spring target
    :data:`WALTZ_FORCE` / K behind its waist centre, towards its back (the dancer leans into the
    hold with the preload, the lean turning with the dancer); hands stay parked (the robot is led
    by the waist alone: hands pressing the skin would add contact tasks of their own)."""
    start = waltz_start(sim)
    chor = waltz_choreography(tempo, WALTZ_INTRO, WALTZ_OUTRO)
    c0, s0 = math.cos(WALTZ_START_YAW), math.sin(WALTZ_START_YAW)
    rot0 = np.array([[c0, -s0], [s0, c0]])
    lean = WALTZ_FORCE / TORSO.stiffness
    parks = {p.name: PartTarget(np.array(p.parking), np.zeros(3)) for p in sim.parts}

    def script(t: float) -> dict[str, PartTarget]:
        p, psi, v, rate = chor.pose(t)
        yaw = WALTZ_START_YAW + psi
        cy, sy = math.cos(yaw), math.sin(yaw)
        xy = start[:2] + rot0 @ p + lean * np.array([-cy, -sy])
        vxy = rot0 @ v + lean * rate * np.array([sy, -cy])
        out = dict(parks)
        out["person_torso"] = PartTarget(np.array([xy[0], xy[1], start[2]]),
                                         np.array([vxy[0], vxy[1], 0.0]), yaw, rest=start)
        return out

    return script


def waltz_duration(tempo: str = "paper") -> float:
    """Length of the waltz at ``tempo``: intro, the routine and the outro [s]."""
    return waltz_choreography(tempo, WALTZ_INTRO, WALTZ_OUTRO).duration


# ---------------------------------------------------------------------------------------------

CENTRING_PARAMS = {**TABLE_II, **_admittance(paper.CENTRING)}
SLIDING_PARAMS = {
    **TABLE_II,
    "region_margin": paper.REGION_MARGIN,
    **_admittance(paper.TRACKING),
}
WHOLE_BODY_PARAMS = {**TABLE_II, **_admittance(paper.WHOLE_BODY)}
WALTZ_FOLLOW = paper.Admittance(
    inertia=(0.1, 0.1, 0.1, 0.1, 0.1, 0.01),
    damping=(100.0, 100.0, 200.0, 200.0, 200.0, 0.2),
    stiffness=paper.six(0.0),
)
"""The default waltz admittance (docs/wholebody_controller.md, "Following a turning partner"):
the paper's Λ = 0.1, D = 200 except the horizontal translation, D = 100 N·s/m (the preload closes
at 10 N / D = 0.1 m/s, twice the paper's, so a partner stepping away is followed), and the
rotation about the vertical in its own units, Λ = 0.01 kg·m², D = 0.2 N·m·s/rad (a lead moment of
10 N over 2.6 mm turns the link at the paper tempo's 0.13 rad/s)."""
WALTZ_K_ETA = 1000.0
"""Track-force gain of the waltz [N/m]: a partner stepping along the forearm at the paper tempo's
0.055 m/s leaves Ω_d by 0.055 · D / k_η ≈ 5 mm (with Table II's 200: 2.7 cm, and the contact
slides towards the link's end)."""
WALTZ_DANCE_RANGE = 0.03
"""Half width of the q_dance band of the default set [rad]: with the paper's 0.1 the arms absorb
the first ≈ 17° of a turn at the band's edges and the base, which carries the partner, lags the
partner's heading by that much (measured: 25° max / 14° RMS heading drift over the first 45 s,
against 16° / 9° with 0.03)."""
WALTZ_PAPER_PARAMS = {
    **TABLE_II,
    **_admittance(paper.WALTZ),
    "q_dance_enabled": True,
    "q_dance": list(Q_DANCE),
    "q_dance_range": paper.Q_DANCE_HALF_WIDTH,
    f"{WALTZ_LINK}.priority_lock": paper.WALTZ_PRIORITY_LOCK,
    f"{WALTZ_LINK}.desired_force": [0.0, -WALTZ_FORCE, 0.0],
}
"""Sec. VI-B's literal set (``phri sim --params paper``)."""
WALTZ_PARAMS = {
    **WALTZ_PAPER_PARAMS,
    **_admittance(WALTZ_FOLLOW),
    "k_eta": WALTZ_K_ETA,
    "q_dance_range": WALTZ_DANCE_RANGE,
    "lead_moment": True,
}
"""The default waltz set: the paper's with :data:`WALTZ_FOLLOW`, :data:`WALTZ_K_ETA`,
:data:`WALTZ_DANCE_RANGE` and the lead moment (F1) with the carried reference (F2) of
:mod:`wholebody_controller.following`."""

WALTZ_TEMPO_VELOCITY_LIMIT = 0.5
"""``velocity_limit`` of the `tempo` waltz [m/s, rad/s]: the mecanum base's 0.5 m/s, the
tightest of the robot's own limits (base 1.0 rad/s, UR16e joints 2.09–3.14 rad/s); the
controller has one bound for every axis."""
WALTZ_TEMPO_PARAMS = {**WALTZ_PARAMS, "velocity_limit": WALTZ_TEMPO_VELOCITY_LIMIT}
"""The default set at the robot's own speed limit (:data:`WALTZ_TEMPO_VELOCITY_LIMIT`)."""

WALTZ_SHORT = 30.0
"""CI length of the waltz [s]: the hold, the closed change forward and the first natural turn's
first bar (a turn of 90°, the step away from the forearm, the side step along it)."""

SCENARIOS: dict[str, Scenario] = {
    s.name: s
    for s in (
        Scenario("centring", "Fig. 6: even press, then presses on both sides of a link",
                 11.0, 11.0, Q_HOME, CENTRING_PARAMS, centring_script, "centring",
                 {"torque_limit": list(paper.TORQUE_LIMIT)}),
        Scenario("sliding", "Fig. 7: press the middle of a link, slide forward and back",
                 16.0, 10.0, Q_HOME, SLIDING_PARAMS, sliding_script, "tracking"),
        Scenario("whole_body", "Fig. 8: periodic touches on the three skin links",
                 SCENARIO_WHOLE_BODY_LENGTH, 12.0, Q_HOME, WHOLE_BODY_PARAMS,
                 whole_body_script, "whole_body"),
        Scenario("waltz", "Fig. 1: the partner leads a waltz (paper tempo) through the waist",
                 waltz_duration("paper"), WALTZ_SHORT, Q_WALTZ, WALTZ_PARAMS, waltz_script,
                 "waltz", settle=WALTZ_SETTLE),
        Scenario("waltz_tempo", "Fig. 1 at a real slow-waltz tempo (bar 2 s)",
                 waltz_duration("tempo"), waltz_duration("tempo"), Q_WALTZ, WALTZ_TEMPO_PARAMS,
                 partial(waltz_script, tempo="tempo"), "waltz", settle=WALTZ_SETTLE),
        Scenario("waltz_paper", "Fig. 1 (paper tempo) with the paper's literal parameter set",
                 waltz_duration("paper"), WALTZ_SHORT, Q_WALTZ, WALTZ_PAPER_PARAMS, waltz_script,
                 "waltz", settle=WALTZ_SETTLE),
    )
}

