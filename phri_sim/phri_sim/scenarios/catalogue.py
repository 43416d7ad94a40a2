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
  normal, then slides forward, holds, slides backward, holds (the robot following brings the
  contact back toward Ω_d). Λ = 0.5 I, D = diag(40, 40, 500, 40, 40, 40),
  K = 0; desired-region margin 0.01 m.
* ``whole_body`` (Fig. 8): periodic touches on the three skin links in turn.
  Λ = 0.5 I, D = 60 I, K = 40 I.
* ``waltz`` (Fig. 1, Sec. VI-B): from a hold resting at the 10 N preload (settled before t = 0),
  the torso walks two waltz boxes (forward, side, close, back, side, close; minimum-jerk steps),
  the second turned by 90°, a minute in all; the robot follows through its left forearm on the
  (soft) waist alone: arms held within ±0.1 rad of q_dance (:data:`Q_DANCE`, the wrist turned
  outward), left-forearm priority locked at 1, desired force 10 N to the right (base frame).
  Λ = 0.1 I, D = 200 I, K = 0.

The hands of centring, sliding and whole_body are :class:`~phri_sim.scenarios.hand.ForceHand`: they
press with a target normal force on the link's current surface, let go for real, never jump, and
every touch must land on skin (:class:`~phri_sim.scenarios.hand.TouchOffSkinError` otherwise).
Centring, sliding and whole_body also set the controller's documented Ω_d deviations
(:data:`REGION_SETTINGS`; ``PARAMETER_SETS[name]["literal"]`` without them).

Table II values (q̇ ∈ [−0.15, 0.15], k_η = 200, b = 4, K_p = 5, ψ_thr = 1e-4, ε = 0.1, h = 0.15,
100 Hz) are the controller's defaults and are repeated in every parameter set for clarity. Every
value comes from :mod:`phri_common.paper`, the skin links from the robot description.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import partial
from typing import Any

import numpy as np
from numpy.typing import NDArray

from phri_common import paper
from phri_description.description import SKIN_LINKS, robot_description
from phri_sim.scenarios.hand import ForceHand, Touch, make_touch
from phri_sim.scenarios.motion_profiles import minimum_jerk
from phri_sim.scenarios.partner_variability import (
    PosturalSway,
    Sway,
    Variability,
    deviate,
    human_variability,
)
from phri_sim.scenarios.waltz_choreography import TEMPOS, Choreography, routine
from phri_sim.world.person_body import TORSO, WAIST_RADIUS, PartTarget
from phri_sim.world.simulation import Simulation
from wholebody_controller.config import ROBOT_ACCELERATION_LIMITS

FloatArray = NDArray[np.float64]
Script = Callable[[float], dict[str, PartTarget]]

Q_LEFT_HOME: tuple[float, ...] = (0.0, -0.3, 0.3, 0.0, 0.0, 0.0)
"""Left arm start (and the waltz's q_dance): upper arm turned out, forearm parallel to the base
x axis at 1.06 m, elbow bent (away from the straight-arm singularity) [rad]."""
Q_RIGHT_HOME: tuple[float, ...] = (0.0, 0.3, -0.3, 0.0, 0.0, 0.0)
"""Right arm start (and q_dance), the left arm's counterpart [rad]."""
Q_HOME: tuple[float, ...] = (0.0, 0.0, 0.0, *Q_LEFT_HOME, *Q_RIGHT_HOME)
"""Start configuration q (15): base at the origin, arms at home."""

PAPER_ACCELERATION_LIMITS = [1000.0] * 15
"""``acceleration_limits`` of the paper's experiments [m/s², rad/s²]: the paper's QP (22)–(23)
bounds velocities only, so its sets leave the commands' rate of change free (1000 per second
squared is beyond any actuator: the bound never acts). The default waltz runs at the robot's
rated accelerations (:data:`ROBOT_ACCELERATION_LIMITS`)."""

TABLE_II: dict[str, Any] = {
    "velocity_limit": paper.VELOCITY_LIMIT,
    "acceleration_limits": PAPER_ACCELERATION_LIMITS,
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
        bars: the following bars it is judged by, a name of
            :data:`phri_sim.evaluation.following_metrics.BAR_SETS` (``paper``: pose and force;
            ``waltz``: every bar of the default waltz; ``tempo``: the faster rungs'; ``sway``).
        partner: how the partner departs from the script (tempo scale, sway seed, the other
            hand), for the metrics; empty for the scripted partner.
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
    bars: str = "paper"
    partner: dict[str, Any] = field(default_factory=dict)


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
# Geometry helpers: where on a patch a hand presses (the hands themselves: phri_sim.scenarios.hand).
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


def _parked(part: str, sim: Simulation) -> PartTarget:
    spec = next(p for p in sim.parts if p.name == part)
    return PartTarget(np.array(spec.parking), np.zeros(3))


def _hands_script(sim: Simulation, touches: dict[str, list[Touch]]) -> Script:
    """Both hands (:class:`~phri_sim.scenarios.hand.ForceHand`, parked when they have no touch) and
    the torso parked."""
    hands = {name: ForceHand(sim, _parked(name, sim).position, touches.get(name, []))
             for name in ("person_left_hand", "person_right_hand")}
    park_t = _parked("person_torso", sim)

    def script(t: float) -> dict[str, PartTarget]:
        out = {name: hand(t) for name, hand in hands.items()}
        out["person_torso"] = park_t
        return out

    return script


UP = (0.0, 0.0, 1.0)
DOWN = (0.0, 0.0, -1.0)
SIDE = (0.0, 1.0, 0.0)

# ---------------------------------------------------------------------------------------------
# 1. Contact centring (Fig. 6)
# ---------------------------------------------------------------------------------------------

CENTRING_FORCE = 15.0
"""Target normal force of each press [N]."""
CENTRING_EVEN = (1.0, 3.0)
"""Scenario ① (Fig. 6): the right hand presses evenly on the middle of the right forearm from
above: (t_on, t_off) [s]; the force is gone at t_off + 0.2 s."""
CENTRING_TWO_SIDED = (6.0, 8.0)
"""Scenario ②: two hands press the right forearm on opposite sides at both ends: (t_on, t_off)."""
CENTRING_S = (0.18, 0.235, 0.125)
"""Axial positions on the patch [m]: the even press, the top press towards the elbow end, the
bottom press towards the wrist end (5.5 cm either side of the middle: 15 N × 0.11 m = 1.65 N·m
of torque about the contact centre, above the 1.2 N·m clamp; nearer the elbow the top hand
would also press the upper arm)."""


def centring_script(sim: Simulation) -> Script:
    """① even press on the middle of the right forearm from above; ② presses from above near
    the elbow end (right hand) and from below near the wrist end (left hand); each with
    :data:`CENTRING_FORCE` held by :class:`~phri_sim.scenarios.hand.ForceHand`, then a real
    release."""
    f = CENTRING_FORCE
    mid, top, bottom = CENTRING_S
    return _hands_script(sim, {
        "person_right_hand": [make_touch(sim, "right_forearm", mid, UP, *CENTRING_EVEN, f),
                              make_touch(sim, "right_forearm", top, UP, *CENTRING_TWO_SIDED, f)],
        "person_left_hand": [make_touch(sim, "right_forearm", bottom, DOWN,
                                        *CENTRING_TWO_SIDED, f)],
    })


# ---------------------------------------------------------------------------------------------
# 2. Contact-change tracking (Fig. 7)
# ---------------------------------------------------------------------------------------------

SLIDE_FORCE = 12.0
"""Target normal force of the sliding hand [N]."""
SLIDE_AMPLITUDE = 0.03
"""How far the hand slides forward / backward along the link (world) [m]: the contact region
(≈ 4 cm long under a 12 N press) then sticks out 2 cm past Ω_d (margin 1 cm)."""
SLIDE_MOVES: tuple[tuple[float, float, float], ...] = (
    (2.0, 1.0, 1.0), (6.0, 1.5, -1.0), (10.5, 1.5, 1.0))
"""The slides: (start [s], duration [s], end position in units of :data:`SLIDE_AMPLITUDE`);
the hand holds still between them (minimum-jerk moves), so whether the contact returns into
Ω_d is up to the robot following it (Fig. 7: "under the robot's movement, the contact naturally
slides back to the initial position")."""
SLIDE_RELEASE = 14.0
"""The hand lets go at this time [s] (2 s before the end of the full run)."""


def slide_offset(t: float) -> float:
    """The sliding hand's tangential offset along the link (world frame) at ``t`` [m]:
    :data:`SLIDE_MOVES`, each a minimum-jerk move, still in between."""
    position = 0.0
    for start, duration, end in SLIDE_MOVES:
        if t <= start:
            break
        target = end * SLIDE_AMPLITUDE
        position += (target - position) * minimum_jerk((t - start) / duration)
    return position


def sliding_script(sim: Simulation) -> Script:
    """Press the middle of the left forearm from above (from 0.5 s, :data:`SLIDE_FORCE` held by
    :class:`~phri_sim.scenarios.hand.ForceHand`; still until 2 s, so Ω_d is locked on a still hand),
    slide forward, backward and forward along the link (:func:`slide_offset`, scripted in the world,
    so the robot following the hand brings the contact back on the skin), then let go at
    :data:`SLIDE_RELEASE`."""
    touch = make_touch(sim, "left_forearm", 0.18, UP, 0.5, SLIDE_RELEASE, SLIDE_FORCE,
                       slide=slide_offset)
    return _hands_script(sim, {"person_left_hand": [touch]})


# ---------------------------------------------------------------------------------------------
# 3. Whole-body pHRI (Fig. 8)
# ---------------------------------------------------------------------------------------------

TOUCH_FORCE = 15.0
"""Target normal force of each whole-body touch [N]."""
TOUCH_PERIOD = 4.0
"""Each link is touched for 2 s of every 4 s slot, links in turn."""
SCENARIO_WHOLE_BODY_LENGTH = 24.0
"""Full length of the whole-body scenario [s]."""
WHOLE_BODY_SPOTS: tuple[tuple[str, str, float, tuple[float, float, float]], ...] = (
    ("person_left_hand", "left_upper_arm", 0.24, SIDE),
    ("person_left_hand", "left_forearm", 0.18, SIDE),
    ("person_right_hand", "right_forearm", 0.18, UP),
)
"""(hand, patch, s [m], from direction) of the three touched links, in turn: the left hand
touches the left upper arm and forearm from the outside (+y), the right hand the right forearm
from above."""


def whole_body_script(sim: Simulation) -> Script:
    """One link per :data:`TOUCH_PERIOD` slot in turn (:data:`WHOLE_BODY_SPOTS`), each touch
    :data:`TOUCH_FORCE` for 2 s from 0.5 s into its slot, held by
    :class:`~phri_sim.scenarios.hand.ForceHand`; between touches a hand lifts off and travels."""
    slots = math.ceil(SCENARIO_WHOLE_BODY_LENGTH / TOUCH_PERIOD)
    touches: dict[str, list[Touch]] = {"person_left_hand": [], "person_right_hand": []}
    for slot in range(slots):
        hand, patch, s, side = WHOLE_BODY_SPOTS[slot % len(WHOLE_BODY_SPOTS)]
        t_on = slot * TOUCH_PERIOD + 0.5
        touches[hand].append(make_touch(sim, patch, s, side, t_on, t_on + 2.0, TOUCH_FORCE))
    return _hands_script(sim, touches)


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


@dataclass(frozen=True)
class Partner:
    """How the waltz partner departs from the scripted routine (docs/phri_sim.md, "The partner").

    Attributes:
        tempo_scale: K, the routine danced K times faster (beats K times shorter, steps as
            long; K = 1: the tempo's own) [1].
        sway: seed of the human variability (:mod:`phri_sim.scenarios.partner_variability`:
            postural sway, hesitations, small deviations); ``None`` = none.
        hand: the partner's other hand rests on the robot's right forearm (Fig. 1's hold:
            :data:`HAND_REST`).
    """

    tempo_scale: float = 1.0
    sway: int | None = None
    hand: bool = True

    def __post_init__(self) -> None:
        if not (math.isfinite(self.tempo_scale) and self.tempo_scale > 0.0):
            raise ValueError(f"tempo scale {self.tempo_scale}: must be a finite number > 0")
        if self.sway is not None and self.sway < 0:
            raise ValueError(f"sway seed {self.sway}: must be >= 0")

    def describe(self) -> dict[str, Any]:
        """The partner as reported in the metrics."""
        return {"tempo_scale": self.tempo_scale, "sway": self.sway, "hand": self.hand}


HAND_REST_PATCH = "right_forearm"
"""Where the partner's other hand rests (Fig. 1's hold: the robot's left forearm lies across the
partner's back like a leader's right arm; the robot's right forearm, in front of the partner at
chest height, is where the leader's left hand would hold the partner's right hand). A link of its
own: contact estimation reports it apart from the waist on the left forearm."""
HAND_REST_S = 0.18
"""Axial position of the resting hand on its patch (the middle, in front of the partner) [m]."""
HAND_REST_FORCE = 3.0
"""The resting hand's normal force [N]: a relaxed hand and forearm partly resting their weight,
pressing from above (a light second contact; the leading waist holds 10 N)."""


def _dance(tempo: str, partner: Partner) -> tuple[Choreography, Variability | None]:
    """The routine at ``tempo`` scaled by the partner's tempo scale and deviated by its sway."""
    base = TEMPOS[tempo]
    pace = dataclasses.replace(base, name=f"{tempo}x{partner.tempo_scale:g}",
                               beat=base.beat / partner.tempo_scale)
    beats = routine(pace)
    if partner.sway is None:
        return Choreography(beats, pace.beat, WALTZ_INTRO, WALTZ_OUTRO), None
    dance = (WALTZ_INTRO, WALTZ_INTRO + len(beats) * pace.beat)
    var = human_variability(Sway(partner.sway), len(beats), dance)
    beats = deviate(beats, var.step_factors, var.turn_factors)
    return Choreography(beats, pace.beat, WALTZ_INTRO, WALTZ_OUTRO), var


def waltz_script(sim: Simulation, tempo: str = "paper", partner: Partner = Partner()) -> Script:
    """The torso dances :func:`~phri_sim.scenarios.waltz_choreography.routine` at ``tempo`` (and
    the partner's tempo scale, sway, hesitations and deviations, :class:`Partner`) from
    :func:`waltz_start` (heading :data:`WALTZ_START_YAW`), its spring target :data:`WALTZ_FORCE`
    / K behind its waist centre, towards its back (the dancer leans into the hold with the
    preload, the lean turning with the dancer); with ``partner.hand`` the right hand rests on
    the robot's right forearm (:data:`HAND_REST_FORCE`, from the start to the end), the left
    hand stays parked."""
    start = waltz_start(sim)
    chor, var = _dance(tempo, partner)
    c0, s0 = math.cos(WALTZ_START_YAW), math.sin(WALTZ_START_YAW)
    rot0 = np.array([[c0, -s0], [s0, c0]])
    lean = WALTZ_FORCE / TORSO.stiffness
    parks = {p.name: PartTarget(np.array(p.parking), np.zeros(3)) for p in sim.parts}
    hand = None
    if partner.hand:
        end = chor.duration + (0.0 if var is None else var.hesitations.total)
        hand = ForceHand(sim, parks["person_right_hand"].position, [make_touch(
            sim, HAND_REST_PATCH, HAND_REST_S, UP, 0.0, end + 1.0, HAND_REST_FORCE)])

    def script(t: float) -> dict[str, PartTarget]:
        clock, pace = (t, 1.0) if var is None else var.hesitations.clock(t)
        p, psi, v, rate = chor.pose(clock)
        v, rate = v * pace, rate * pace
        if var is not None:
            p, psi, v, rate = _swayed(var.sway, t, p, psi, v, rate)
        yaw = WALTZ_START_YAW + psi
        cy, sy = math.cos(yaw), math.sin(yaw)
        xy = start[:2] + rot0 @ p + lean * np.array([-cy, -sy])
        vxy = rot0 @ v + lean * rate * np.array([sy, -cy])
        out = dict(parks)
        out["person_torso"] = PartTarget(np.array([xy[0], xy[1], start[2]]),
                                         np.array([vxy[0], vxy[1], 0.0]), yaw, rest=start)
        if hand is not None:
            out["person_right_hand"] = hand(t)
        return out

    return script


def _swayed(sway: PosturalSway, t: float, p: FloatArray, psi: float, v: FloatArray,
            rate: float) -> tuple[FloatArray, float, FloatArray, float]:
    """The pose (position and velocity in the dance frame [m, m/s], heading and its rate [rad,
    rad/s]) with the postural sway at ``t`` added in the dancer's own frame."""
    off, off_rate = sway.at(t)
    c, s = math.cos(psi), math.sin(psi)
    body = np.array([[c, -s], [s, c]])
    turn = np.array([[-s, -c], [c, -s]])  # d(body)/dψ
    p = p + body @ off[:2]
    v = v + body @ off_rate[:2] + rate * (turn @ off[:2])
    return p, psi + float(off[2]), v, rate + float(off_rate[2])


def waltz_duration(tempo: str = "paper", partner: Partner = Partner()) -> float:
    """Length of the waltz at ``tempo`` danced by ``partner``: intro, the routine (with its
    hesitations) and the outro [s]."""
    chor, var = _dance(tempo, partner)
    return chor.duration + (0.0 if var is None else var.hesitations.total)


# ---------------------------------------------------------------------------------------------

REGION_WINDOW = 0.5
"""Onset window of Ω_d [s] (controller ``region_window``, a documented deviation,
docs/paper_vs_phri.md): covers the footprint's build-up under a press rising in 0.3 s, and the
second hand of a two-sided press landing a few periods after the first."""
REGION_HYSTERESIS = 0.0075
"""Engage threshold of a face of Ω_i [m] (controller ``region_hysteresis``, a documented
deviation): one taxel pitch (7.5 mm), so a boundary taxel flickering does not toggle μ."""
REGION_SETTINGS = {"region_window": REGION_WINDOW, "region_hysteresis": REGION_HYSTERESIS}

CENTRING_PARAMS = {**TABLE_II, **REGION_SETTINGS, **_admittance(paper.CENTRING)}
SLIDING_PARAMS = {
    **TABLE_II,
    "region_margin": paper.REGION_MARGIN,
    **REGION_SETTINGS,
    **_admittance(paper.TRACKING),
}
WHOLE_BODY_PARAMS = {**TABLE_II, **REGION_SETTINGS, **_admittance(paper.WHOLE_BODY)}
WALTZ_FOLLOW = paper.Admittance(
    inertia=(1.0, 1.0, 0.1, 0.1, 0.1, 0.1),
    damping=(100.0, 100.0, 200.0, 200.0, 200.0, 0.2),
    stiffness=paper.six(0.0),
)
"""The default waltz admittance (docs/wholebody_controller.md, "Following a turning partner"):
the paper's Λ = 0.1, D = 200 except

* the horizontal translation, D = 100 N·s/m (the preload closes at 10 N / D = 0.1 m/s, twice the
  paper's, so a partner stepping away is followed) with Λ = 1.0 kg: the skin's force noise
  reaches the command through a 16 Hz low-pass (D/Λ = 100 rad/s) instead of 160 Hz;
* the rotation about the vertical in its own units, D = 0.2 N·m·s/rad (a lead moment of 10 N over
  2.6 mm turns the link at the paper tempo's 0.13 rad/s) with Λ = 0.1 kg·m². Measured on the
  realistic plant (first 40 s, seed 0): with Λ = 0.01 the base's 50 ms of latency and lag turn the
  lead moment's loop into a growing 0.7 Hz yaw oscillation at the 0.15 rad/s limit and the hold
  is lost at 15 s (band 35 %, heading drift 130°); with 0.05 or 0.1 it is held (band 100 %,
  heading drift 6°)."""
WALTZ_K_ETA = 300.0
"""Track-force gain of the waltz [N/m]. The edge of Ω_i moves in steps of one taxel pitch
(7.5 mm) as fringe taxels cross σ_t, and every step changes the track force (10)–(11) by
k_η · 7.5 mm: 7.5 N with 1000 N/m, which on the realistic plant drove the base to its rated
acceleration at every step (waist force above 1 Hz 0.61 N RMS over the first 70 s); 300 N/m makes
the step 2.25 N (0.50 N RMS). A partner stepping along the forearm at the paper tempo's
0.055 m/s leaves Ω_d by 0.055 · D / k_η ≈ 1.8 cm (with Table II's 200: 2.7 cm)."""
WALTZ_DANCE_RANGE = 0.03
"""Half width of the q_dance band of the default set [rad]: with the paper's 0.1 the arms absorb
the first ≈ 17° of a turn at the band's edges and the base, which carries the partner, lags the
partner's heading by that much (measured: 25° max / 14° RMS heading drift over the first 45 s,
against 16° / 9° with 0.03)."""
WALTZ_TURN_FORCE = 20.0
"""The waltz's ``turn_force_limit`` (T1) [N]: the turn is led with the 10 N hold (the dance band
reaches 25 N; the waltz peaks at 21 N), so above 20 N the torque input fades, to nothing at
30 N. Measured (realistic plant, seed 0, the 250 N shove at 20 s): without it the yield ends
at 21.25 s and the decaying push (50 → 5 N), off-centre on the forearm, turns the base at its
0.15 rad/s limit for 2 s, sweeping the unskinned right wrist into the rebounding abdomen:
412 N peak; gated from 30 N to nothing at 60 N, 276 N; with F_t = 20 N, 107 N. The ladder's
×1 and sway1–2 rungs are unchanged to the digit, ×2's peak falls 41.3 → 36.1 N, sway3's drift
8.5 / 11.4 → 5.8 / 8.6 cm (docs/wholebody_controller.md, "Following a turning partner")."""
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
    "turn_force_limit": WALTZ_TURN_FORCE,
    "acceleration_limits": list(ROBOT_ACCELERATION_LIMITS),
}
"""The default waltz set: the paper's with :data:`WALTZ_FOLLOW`, :data:`WALTZ_K_ETA`,
:data:`WALTZ_DANCE_RANGE`, the lead moment (F1) with the carried reference (F2) of
:mod:`wholebody_controller.following`, the torque input gated by the contact force (T1,
:data:`WALTZ_TURN_FORCE`), and commands within the robot's rated accelerations."""

WALTZ_TEMPO_BASE_LIMITS = (0.5, 0.5, 1.0)
"""The mecanum base's own speed limits for the `tempo` waltz: x, y 0.5 m/s, yaw
1.0 rad/s."""
WALTZ_TEMPO_VELOCITY_LIMITS: tuple[float, ...] = (
    *WALTZ_TEMPO_BASE_LIMITS,
    *(math.ceil(1000.0 * v) / 1000.0 for v in robot_description().velocity_limits()[3:]),
)
"""``velocity_limits`` of the `tempo` waltz [m/s, rad/s], q order: the base's
(:data:`WALTZ_TEMPO_BASE_LIMITS`), the UR16e joints' own from the description (2.09–3.14 rad/s,
rounded up to 1e-3 so the description's decide)."""
WALTZ_TEMPO_VELOCITY_LIMIT = max(WALTZ_TEMPO_VELOCITY_LIMITS)
"""``velocity_limit`` of the `tempo` waltz: no tighter than any per-axis bound (Table II's single
0.15 does not apply at a real tempo)."""
WALTZ_TEMPO_PARAMS = {**WALTZ_PARAMS, "velocity_limit": WALTZ_TEMPO_VELOCITY_LIMIT,
                      "velocity_limits": list(WALTZ_TEMPO_VELOCITY_LIMITS)}
"""The default set at the robot's own per-axis speed limits
(:data:`WALTZ_TEMPO_VELOCITY_LIMITS`)."""

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
                 "waltz", settle=WALTZ_SETTLE, bars="waltz", partner=Partner().describe()),
        Scenario("waltz_tempo", "Fig. 1 at a real slow-waltz tempo (bar 2 s)",
                 waltz_duration("tempo"), waltz_duration("tempo"), Q_WALTZ, WALTZ_TEMPO_PARAMS,
                 partial(waltz_script, tempo="tempo"), "waltz", settle=WALTZ_SETTLE,
                 bars="tempo", partner=Partner().describe()),
        Scenario("waltz_paper", "Fig. 1 (paper tempo) with the paper's literal parameter set",
                 waltz_duration("paper"), WALTZ_SHORT, Q_WALTZ, WALTZ_PAPER_PARAMS, waltz_script,
                 "waltz", settle=WALTZ_SETTLE, bars="waltz", partner=Partner().describe()),
    )
}

LITERAL_REGION = {"region_window": 0.0, "region_hysteresis": 0.0}
"""The paper's literal Ω_d: locked on the first frame of a touch, (10)–(11) without hysteresis."""
PARAMETER_SETS: dict[str, dict[str, dict[str, Any]]] = {
    name: {"phri": params, "literal": {**params, **LITERAL_REGION}}
    for name, params in (("centring", CENTRING_PARAMS), ("sliding", SLIDING_PARAMS),
                         ("whole_body", WHOLE_BODY_PARAMS))
}
"""Selectable controller parameter sets per scenario: ``phri`` (the scenario's own: the paper's
values with the documented Ω_d deviations) and ``literal`` (the paper's values only)."""


WALTZ_TEMPO_OF = {"waltz": "paper", "waltz_paper": "paper", "waltz_tempo": "tempo"}
"""The choreography tempo of each waltz scenario of the catalogue."""


def with_partner(scenario: Scenario, partner: Partner) -> Scenario:
    """A waltz scenario of the catalogue (any parameter set) danced by ``partner``: its script,
    length (CI length: the shorter of its own and the new length), bars (``tempo`` for the
    ``tempo`` choreography and for K > 1, ``sway`` with sway, else ``waltz``) and the partner in
    the metrics. ValueError for a scenario that is not a waltz."""
    tempo = WALTZ_TEMPO_OF.get(scenario.name)
    if tempo is None or scenario.metrics != "waltz":
        raise ValueError(f"scenario {scenario.name!r}: a partner applies to the waltz only "
                         f"({', '.join(WALTZ_TEMPO_OF)})")
    duration = waltz_duration(tempo, partner)
    fast = tempo == "tempo" or partner.tempo_scale > 1.0
    bars = "tempo" if fast else ("sway" if partner.sway is not None else "waltz")
    return dataclasses.replace(
        scenario, duration=duration, short_duration=min(scenario.short_duration, duration),
        make_script=partial(waltz_script, tempo=tempo, partner=partner), bars=bars,
        partner={"tempo": tempo, **partner.describe()})


def scenario_named(name: str) -> Scenario:
    """The catalogue's scenario ``name`` (:data:`SCENARIOS`); ValueError naming the known ones
    otherwise."""
    try:
        return SCENARIOS[name]
    except KeyError:
        raise ValueError(f"unknown scenario {name!r}; known: {', '.join(SCENARIOS)}") from None


def with_parameter_set(scenario: Scenario, name: str) -> Scenario:
    """``scenario`` with its controller parameter set ``name`` (:data:`PARAMETER_SETS`; ``phri``
    = the scenario's own); ValueError naming the allowed sets otherwise."""
    sets = PARAMETER_SETS.get(scenario.name, {"phri": scenario.controller_parameters})
    if name not in sets:
        raise ValueError(f"parameter set {name!r} refused for scenario {scenario.name!r}: "
                         f"allowed {sorted(sets)}")
    return dataclasses.replace(scenario, controller_parameters=dict(sets[name]))
