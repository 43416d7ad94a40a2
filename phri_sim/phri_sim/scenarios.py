"""The paper's four experiments (Sec. VI, design §6) as scripted scenarios (pure, no rclpy).

A :class:`Scenario` bundles what one experiment needs: the robot's start configuration, the
controller parameters of the paper for that experiment (:attr:`Scenario.controller_parameters`,
plain names and values the bringup can pass as ROS parameters or dump to YAML with
:func:`parameters_yaml`), its length (and a shortened CI length), and a script that moves the
person's spring targets over time. Scripts are functions of simulation time only, so a scenario is
deterministic for a seed (the seed drives only the skin noise).

Scenarios (``SCENARIOS``):

* ``centring`` (Fig. 6): one hand presses evenly on the middle of the right forearm, lets go,
  then two hands press the same link on opposite sides at both ends (a torque about the centre).
  Λ = 0.5 I, D = 40 I, K = 0; torque limit τ(2) ≤ 1.2 (contact estimation).
* ``sliding`` (Fig. 7): a hand presses the middle of the left forearm mostly along the link's
  normal and slides forward and back along the link. Λ = 0.5 I, D = diag(40, 40, 500, 40, 40, 40),
  K = 0; desired-region margin 0.01 m.
* ``whole_body`` (Fig. 8): periodic touches on the three skin links in turn.
  Λ = 0.5 I, D = 60 I, K = 40 I.
* ``waltz`` (Fig. 1, Sec. VI-B): the torso walks two waltz boxes (forward, side, close, back,
  side, close), the second turned by 90°, about a minute; the robot follows through its left
  forearm on the waist alone: arms held within ±0.1 rad of q_dance, left-forearm priority locked
  at 1, desired force 10 N to the right (base frame). Λ = 0.1 I, D = 200 I, K = 0.

Table II values (q̇ ∈ [−0.15, 0.15], k_η = 200, b = 4, K_p = 5, ψ_thr = 1e-4, ε = 0.1, h = 0.15,
100 Hz) are the controller's defaults and are repeated in every parameter set for clarity.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from phri_description.description import robot_description
from phri_sim.person import HAND_RADIUS, TORSO, WAIST_RADIUS, PartTarget
from phri_sim.sim import Simulation

FloatArray = NDArray[np.float64]
Script = Callable[[float], dict[str, PartTarget]]

SKIN_LINKS: tuple[str, ...] = ("left_upper_arm_link", "left_forearm_link", "right_forearm_link")

Q_LEFT_HOME: tuple[float, ...] = (0.0, -0.3, 0.3, 0.0, 0.0, 0.0)
"""Left arm start (and the waltz's q_dance): upper arm turned out, forearm parallel to the base
x axis at 1.06 m, elbow bent (away from the straight-arm singularity) [rad]."""
Q_RIGHT_HOME: tuple[float, ...] = (0.0, 0.3, -0.3, 0.0, 0.0, 0.0)
"""Right arm start (and q_dance), the left arm's counterpart [rad]."""
Q_HOME: tuple[float, ...] = (0.0, 0.0, 0.0, *Q_LEFT_HOME, *Q_RIGHT_HOME)
"""Start configuration q (15): base at the origin, arms at home."""

TABLE_II: dict[str, Any] = {
    "velocity_limit": 0.15,
    "k_eta": 200.0,
    "b": 4.0,
    "k_p": 5.0,
    "psi_thr": 1e-4,
    "epsilon": 0.1,
    "horizon": 0.15,
    "rate_hz": 100.0,
}
"""The paper's Table II and Sec. VI settings (controller parameter names)."""


def _admittance(inertia: list[float], damping: list[float], stiffness: list[float]
                ) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for link in SKIN_LINKS:
        out[f"{link}.inertia"] = list(inertia)
        out[f"{link}.damping"] = list(damping)
        out[f"{link}.stiffness"] = list(stiffness)
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


# ---------------------------------------------------------------------------------------------
# 1. Contact centring (Fig. 6)
# ---------------------------------------------------------------------------------------------

CENTRING_FORCE = 15.0
"""Force of each press [N]."""


def centring_script(sim: Simulation) -> Script:
    """Even press on the middle of the right forearm (1–4 s), release; then presses from above
    near the elbow end and from below near the wrist end (6–9 s), release."""
    up = np.array([0.0, 0.0, 1.0])
    mid, n_mid, _ = press_geometry(sim, "right_forearm", 0.18, up)
    top, n_top, _ = press_geometry(sim, "right_forearm", 0.25, up)
    bottom, n_bottom, _ = press_geometry(sim, "right_forearm", 0.11, -up)
    park_l = _parked("person_left_hand", sim)
    park_t = _parked("person_torso", sim)

    def script(t: float) -> dict[str, PartTarget]:
        if t < 5.0:
            right = _press_target(mid, n_mid, CENTRING_FORCE, t, 1.0, 4.0)
            left = park_l
        else:
            right = _press_target(top, n_top, CENTRING_FORCE, t, 6.0, 9.0)
            left = _press_target(bottom, n_bottom, CENTRING_FORCE, t, 6.0, 9.0)
        return {"person_right_hand": right, "person_left_hand": left, "person_torso": park_t}

    return script


# ---------------------------------------------------------------------------------------------
# 2. Contact-change tracking (Fig. 7)
# ---------------------------------------------------------------------------------------------

SLIDE_FORCE = 12.0
SLIDE_AMPLITUDE = 0.05
SLIDE_PERIOD = 6.0


def sliding_script(sim: Simulation) -> Script:
    """Press the middle of the left forearm from above (0.5–1.5 s), then slide ± 5 cm along the
    link (sinusoid, 6 s period), then let go 2 s before the end."""
    up = np.array([0.0, 0.0, 1.0])
    mid, normal, axis = press_geometry(sim, "left_forearm", 0.18, up)
    park_r = _parked("person_right_hand", sim)
    park_t = _parked("person_torso", sim)

    def script(t: float) -> dict[str, PartTarget]:
        slide_t = max(t - 2.0, 0.0)
        # Sinusoid with a smooth start: amplitude ramps in over the first period.
        env = smoothstep(slide_t / SLIDE_PERIOD)
        w = 2.0 * math.pi / SLIDE_PERIOD
        offset = SLIDE_AMPLITUDE * env * math.sin(w * slide_t)
        rate = SLIDE_AMPLITUDE * env * w * math.cos(w * slide_t) if t > 2.0 else 0.0
        press = _press_target(mid, normal, SLIDE_FORCE, t, 0.5, 1e9)
        return {
            "person_left_hand": PartTarget(press.position + axis * offset,
                                           press.velocity + axis * rate),
            "person_right_hand": park_r,
            "person_torso": park_t,
        }

    return script


# ---------------------------------------------------------------------------------------------
# 3. Whole-body pHRI (Fig. 8)
# ---------------------------------------------------------------------------------------------

TOUCH_FORCE = 15.0
TOUCH_PERIOD = 4.0
"""Each link is touched for 2 s of every 4 s slot, links in turn."""


def whole_body_script(sim: Simulation) -> Script:
    """The left hand touches the left upper arm and the left forearm (from the outside, +y), the
    right hand the right forearm (from above), one link per 4 s slot in turn."""
    side = np.array([0.0, 1.0, 0.0])
    up = np.array([0.0, 0.0, 1.0])
    presses = [
        ("person_left_hand", *press_geometry(sim, "left_upper_arm", 0.24, side)[:2]),
        ("person_left_hand", *press_geometry(sim, "left_forearm", 0.18, side)[:2]),
        ("person_right_hand", *press_geometry(sim, "right_forearm", 0.18, up)[:2]),
    ]
    park = {p.name: PartTarget(np.array(p.parking), np.zeros(3)) for p in sim.parts}

    def script(t: float) -> dict[str, PartTarget]:
        out = dict(park)
        slot = int(t // TOUCH_PERIOD)
        hand, point, normal = presses[slot % 3]
        t_on = slot * TOUCH_PERIOD + 0.5
        out[hand] = _press_target(point, normal, TOUCH_FORCE, t, t_on, t_on + 2.0)
        return out

    return script


# ---------------------------------------------------------------------------------------------
# 4. Waltz (Fig. 1, Sec. VI-B)
# ---------------------------------------------------------------------------------------------

WALTZ_FORCE = 10.0
"""The left forearm's desired force towards the waist (to the right in the base frame) [N]."""
WALTZ_STEP = 0.12
"""Length of a box side [m]."""
WALTZ_STEP_TIME = 5.0
"""Duration of a moving step [s]; a closing step takes half of it."""
WALTZ_INTRO = 4.0
"""Standing still in the hold before the first step [s]."""


def waltz_path() -> tuple[list[float], list[FloatArray], list[float]]:
    """Waypoints of the torso: times [s], planar offsets from the start [m] (world frame), yaw
    [rad]. Box 1: forward (+x), side (away from the robot's left forearm, −y), close, back, side
    (+y), close. Box 2: the same turned by −90° about the couple (a quarter turn to the right)."""
    a, step = WALTZ_STEP, WALTZ_STEP_TIME
    box = [np.array([a, 0.0]), np.array([0.0, -a]), None, np.array([-a, 0.0]),
           np.array([0.0, a]), None]
    times, points, yaws = [0.0, WALTZ_INTRO], [np.zeros(2), np.zeros(2)], [0.0, 0.0]
    t, p, yaw = WALTZ_INTRO, np.zeros(2), 0.0
    for turn in (0.0, -0.5 * math.pi):
        c, s = math.cos(turn), math.sin(turn)
        rot = np.array([[c, -s], [s, c]])
        for move in box:
            if move is None:
                t += 0.5 * step
            else:
                t += step
                p = p + rot @ move
            yaw = turn if move is not None else yaw
            times.append(t)
            points.append(p.copy())
            yaws.append(yaw)
    return times, points, yaws


def _interpolate(times: list[float], values: list[Any], t: float) -> tuple[Any, Any]:
    """Cosine-eased piecewise interpolation: (value, rate) at ``t``."""
    if t <= times[0]:
        return values[0], values[0] * 0.0
    for i in range(1, len(times)):
        if t <= times[i]:
            dt = times[i] - times[i - 1]
            x = (t - times[i - 1]) / dt
            delta = values[i] - values[i - 1]
            return values[i - 1] + delta * smoothstep(x), delta * smoothstep_rate(x, dt)
    return values[-1], values[-1] * 0.0


def waltz_start(sim: Simulation) -> FloatArray:
    """Torso start position: the waist against the inner (−y) side of the left forearm's middle,
    pressed in by the spring so it pushes with the desired force [m]."""
    point, normal, _ = press_geometry(sim, "left_forearm", 0.18, np.array([0.0, -1.0, 0.0]))
    centre = point + normal * WAIST_RADIUS
    return np.array([centre[0], centre[1], centre[2]])


def waltz_preload_direction(sim: Simulation) -> FloatArray:
    """Unit vector from the waist into the left forearm (the spring preload direction)."""
    _, normal, _ = press_geometry(sim, "left_forearm", 0.18, np.array([0.0, -1.0, 0.0]))
    return np.asarray(-normal)


def waltz_script(sim: Simulation) -> Script:
    """The torso follows :func:`waltz_path` from :func:`waltz_start`; hands stay parked (the
    robot is led by the waist alone)."""
    start = waltz_start(sim)
    preload = waltz_preload_direction(sim) * (WALTZ_FORCE / TORSO.stiffness)
    times, points, yaws = waltz_path()
    parks = {p.name: PartTarget(np.array(p.parking), np.zeros(3)) for p in sim.parts}

    def script(t: float) -> dict[str, PartTarget]:
        offset, rate = _interpolate(times, points, t)
        yaw, _ = _interpolate(times, [np.array([y]) for y in yaws], t)
        out = dict(parks)
        # The waist starts just touching; the hold's preload ramps in over the first second.
        out["person_torso"] = PartTarget(
            start + preload * smoothstep(t) + np.array([offset[0], offset[1], 0.0]),
            np.array([rate[0], rate[1], 0.0]),
            float(yaw[0]),
        )
        return out

    return script


def waltz_duration() -> float:
    """Length of the waltz: the path plus 4 s to settle [s]."""
    return waltz_path()[0][-1] + 4.0


# ---------------------------------------------------------------------------------------------

CENTRING_PARAMS = {**TABLE_II, **_admittance([0.5] * 6, [40.0] * 6, [0.0] * 6)}
SLIDING_PARAMS = {
    **TABLE_II,
    "region_margin": 0.01,
    **_admittance([0.5] * 6, [40.0, 40.0, 500.0, 40.0, 40.0, 40.0], [0.0] * 6),
}
WHOLE_BODY_PARAMS = {**TABLE_II, **_admittance([0.5] * 6, [60.0] * 6, [40.0] * 6)}
WALTZ_PARAMS = {
    **TABLE_II,
    **_admittance([0.1] * 6, [200.0] * 6, [0.0] * 6),
    "q_dance_enabled": True,
    "q_dance": [*Q_LEFT_HOME, *Q_RIGHT_HOME],
    "q_dance_range": 0.1,
    "left_forearm_link.priority_lock": 1.0,
    "left_forearm_link.desired_force": [0.0, -WALTZ_FORCE, 0.0],
}

SCENARIOS: dict[str, Scenario] = {
    s.name: s
    for s in (
        Scenario("centring", "Fig. 6: even press, then presses on both sides of a link",
                 11.0, 11.0, Q_HOME, CENTRING_PARAMS, centring_script, "centring",
                 {"torque_limit": [math.inf, math.inf, 1.2]}),
        Scenario("sliding", "Fig. 7: press the middle of a link, slide forward and back",
                 16.0, 10.0, Q_HOME, SLIDING_PARAMS, sliding_script, "tracking"),
        Scenario("whole_body", "Fig. 8: periodic touches on the three skin links",
                 24.0, 12.0, Q_HOME, WHOLE_BODY_PARAMS, whole_body_script, "whole_body"),
        Scenario("waltz", "Fig. 1: the torso leads a waltz box-step through the waist",
                 waltz_duration(), 20.0, Q_HOME, WALTZ_PARAMS, waltz_script, "waltz"),
    )
}


def parameters_yaml(name: str) -> str:
    """ROS 2 parameter YAML (``/**: ros__parameters:``) of a scenario's controller and contact
    estimation settings, for the bringup."""
    import yaml

    sc = SCENARIOS[name]
    doc = {
        "wholebody_controller": {"ros__parameters": dict(sc.controller_parameters)},
        "contact_estimation": {"ros__parameters": dict(sc.estimation_parameters)},
    }
    return str(yaml.safe_dump(doc, sort_keys=False))
