"""The person's physics: soft waist tissue, smooth contacts, spring wrenches, motion profiles.

Each test checks a physical law or a contract against an independent reference (Hooke's law on
the tissue springs, MuJoCo's own quaternion difference, finite differences of the motion
profiles), not numbers copied from a run.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from phri_sim.scenarios.catalogue import (
    SCENARIOS,
    WALTZ_FORCE,
    WALTZ_START_YAW,
    start_scenario,
    waltz_contact,
)
from phri_sim.scenarios.motion_profiles import minimum_jerk, minimum_jerk_rate
from phri_sim.world.person_body import LEFT_HAND, PERSON_PARTS, TORSO, BodyPartSpec, PartTarget
from phri_sim.world.simulation import SimConfig, Simulation
from phri_sim.world.skin_footprint import SkinConfig


def _quiet_sim(**kwargs: object) -> Simulation:
    return Simulation(SimConfig(skin=SkinConfig(noise_std=0.0), **kwargs))  # type: ignore[arg-type]


def _hold_robot(sim: Simulation, seconds: float) -> list[float]:
    """Step with zero commands; return the waist–forearm normal force at every physics step."""
    forces = []
    for _ in range(round(seconds / sim.dt)):
        for channel, n in (("base", 3), ("left", 6), ("right", 6)):
            sim.command(channel, np.zeros(n))
        sim.step()
        forces.append(sim.ground_truth()["left_forearm_link"].normal_force)
    return forces


def _tissue_deflection(sim: Simulation) -> np.ndarray:
    """The waist tissue's slide joints (torso frame x, y) [m], read by name from MuJoCo."""
    return np.array([sim.data.joint(f"{TORSO.tissue_body}_{a}").qpos[0] for a in ("x", "y")])


def test_waltz_starts_resting_at_the_preload() -> None:
    """After the settling the waist presses the forearm with the 10 N preload, and the tissue is
    compressed by F / K_t (Hooke's law of the layer's springs)."""
    sim = _quiet_sim()
    start_scenario(sim, SCENARIOS["waltz"])
    assert sim.time == 0.0
    force = sim.ground_truth()["left_forearm_link"].normal_force
    assert force == pytest.approx(WALTZ_FORCE, rel=0.1)
    assert TORSO.tissue is not None
    deflection = float(np.linalg.norm(_tissue_deflection(sim)))
    assert deflection == pytest.approx(force / TORSO.tissue.stiffness, rel=0.05)
    # The layer is pushed away from the forearm, i.e. opposite to the waist→forearm direction.
    _, inward = waltz_contact(sim)
    yaw = WALTZ_START_YAW  # the slide joints lie in the torso frame
    c, s = math.cos(yaw), math.sin(yaw)
    d = _tissue_deflection(sim)
    world = np.array([c * d[0] - s * d[1], s * d[0] + c * d[1]])
    assert float(world @ inward[:2]) < 0.0


def test_tissue_is_at_least_critically_damped() -> None:
    assert TORSO.tissue is not None
    tissue = TORSO.tissue
    assert tissue.damping / (2.0 * math.sqrt(tissue.stiffness * tissue.mass)) >= 1.0
    # Softer than the robot's admittance damping, so the delayed loop does not ring.
    assert TORSO.tissue.damping < 200.0


def test_turning_waist_keeps_a_continuous_contact() -> None:
    """The torso turns against the held forearm (as in the waltz's turns, at the `tempo`
    tempo's rate): the contact force must not drop to zero at any physics step (a stiff contact
    flickers on and off under a sliding, turning body)."""
    sim = _quiet_sim()
    script = start_scenario(sim, SCENARIOS["waltz"])
    base = script(0.0)["person_torso"]
    omega = -0.5  # rad/s, the waltz turn's peak rate
    forces = []
    for k in range(50):  # 1 s in 20 ms target updates
        t = k * 0.02
        sim.set_target("person_torso", PartTarget(base.position, np.zeros(3),
                                                  base.yaw + omega * t))
        forces.extend(_hold_robot(sim, 0.02))
    assert min(forces) > 0.3 * WALTZ_FORCE


def _lead_after_turn(turn: float) -> tuple[float, float]:
    """(moment about +z (world) of the skin's pressure about the middle of its footprint [N·m],
    total taxel force [N]) after the torso turned by ``turn`` [rad] against the held forearm and
    settled: the skin's own taxel forces (the footprint model), centroid and footprint middle
    along the link axis."""
    sim = _quiet_sim()
    script = start_scenario(sim, SCENARIOS["waltz"])
    base = script(0.0)["person_torso"]
    sim.set_target("person_torso", PartTarget(base.position, np.zeros(3), base.yaw + turn))
    _hold_robot(sim, 1.5)
    forces = sim.skins.clean_forces()["left_forearm"]
    positions = sim.skins.patches["left_forearm"].positions
    touched = forces > 1e-3 * forces.max()
    centroid = forces @ positions / forces.sum()
    middle = 0.5 * (positions[touched].min(axis=0) + positions[touched].max(axis=0))
    rot, _ = sim.link_pose("left_forearm_link")
    lever = rot @ (centroid - middle)
    push = np.array([0.0, forces.sum(), 0.0])  # the waist pushes the forearm along +y (world)
    return float(np.cross(lever, push)[2]), float(forces.sum())


@pytest.mark.parametrize("turn", [math.radians(6.0), -math.radians(6.0)])
def test_turned_back_leads_the_turn_through_the_skin(turn: float) -> None:
    """The stadium waist (its back along world x at the start, the forearm on its +y side):
    turned counter-clockwise, its +x end swings towards the forearm and takes more of the
    pressure, so the pressure's moment about the footprint's middle is +z — the partner's own
    turn direction, the lead the controller's (F1) follows; mirrored for a clockwise turn. Not
    turned, the moment is an order of magnitude smaller."""
    moment, force = _lead_after_turn(turn)
    assert force > 0.3 * WALTZ_FORCE
    assert math.copysign(1.0, moment) == math.copysign(1.0, turn)
    still, _ = _lead_after_turn(0.0)
    assert abs(moment) > 0.02 and abs(still) < 0.2 * abs(moment)


def _expected_wrench(sim: Simulation, part: BodyPartSpec, position: np.ndarray,
                     velocity: np.ndarray, yaw: float) -> tuple[np.ndarray, np.ndarray]:
    """The spring–damper wrench of person_body.py written out per part, with MuJoCo's quaternion
    difference for the orientation error: (force [N], torque [N·m]), world frame."""
    b = sim.person.part_body[part.name]
    dof = sim.person.part_dof[part.name]
    force = part.stiffness * (position - sim.data.xpos[b]) + part.damping * (
        velocity - sim.data.qvel[dof : dof + 3])
    horizontal = math.hypot(force[0], force[1])
    if horizontal > part.max_push:  # person_body.py, "A person who stops pushing"
        force[:2] *= part.max_push / horizontal
    quat = np.array([math.cos(0.5 * yaw), 0.0, 0.0, math.sin(0.5 * yaw)])
    err = np.zeros(3)
    mujoco.mju_subQuat(err, quat, sim.data.xquat[b])
    torque = sim.data.xmat[b].reshape(3, 3) @ (
        part.rot_stiffness * err - part.rot_damping * sim.data.qvel[dof + 3 : dof + 6])
    return force, torque


def test_person_wrench_matches_mujoco_quaternion_difference() -> None:
    """The vectorised spring–damper wrench equals the per-part formula with mju_subQuat."""
    sim = _quiet_sim()
    rng = np.random.default_rng(4)
    for part in PERSON_PARTS:
        adr = sim.person.part_qpos[part.name]
        q = rng.normal(size=4)
        sim.data.qpos[adr + 3 : adr + 7] = q / np.linalg.norm(q)
        dof = sim.person.part_dof[part.name]
        sim.data.qvel[dof : dof + 6] = rng.normal(size=6)
        sim.set_target(part.name, PartTarget(rng.normal(size=3), rng.normal(size=3),
                                             float(rng.uniform(-3, 3))))
    mujoco.mj_forward(sim.model, sim.data)
    sim.person.apply_wrenches(sim.time)
    for part in PERSON_PARTS:
        target = sim.person.targets[part.name]
        force, torque = _expected_wrench(sim, part, target.position, target.velocity, target.yaw)
        b = sim.person.part_body[part.name]
        np.testing.assert_allclose(sim.data.xfrc_applied[b, :3], force, atol=1e-9)
        np.testing.assert_allclose(sim.data.xfrc_applied[b, 3:], torque, atol=1e-9)


@pytest.mark.parametrize(("distance", "expected"), [(0.05, 600.0 * 0.05), (1.0, 80.0)])
def test_the_torso_pushes_at_most_a_persons_push(distance: float, expected: float) -> None:
    """A torso at rest 5 cm from its target pulls with K·d = 30 N; 1 m away (a partner who
    dances on while the robot has stopped) with 80 N, towards the target, the vertical part
    untouched (person_body.py, "A person who stops pushing")."""
    sim = _quiet_sim()
    b = sim.person.part_body[TORSO.name]
    start = sim.data.xpos[b].copy()
    direction = np.array([0.6, -0.8, 0.0])
    sim.set_target(TORSO.name, PartTarget(start + distance * direction + [0.0, 0.0, 0.01],
                                          np.zeros(3), 0.0))
    sim.data.qvel[sim.person.part_dof[TORSO.name] : sim.person.part_dof[TORSO.name] + 3] = 0.0
    sim.person.apply_wrenches(sim.time)
    force = sim.data.xfrc_applied[b, :3]
    assert TORSO.stiffness == 600.0 and TORSO.max_push == 80.0
    np.testing.assert_allclose(force[:2], expected * direction[:2], rtol=1e-9)
    assert force[2] == pytest.approx(600.0 * 0.01)


def test_target_moves_with_its_velocity_between_updates() -> None:
    """Set at t₁ with velocity v, the target pulls at t towards p + v (t − t₁), not p."""
    sim = _quiet_sim()
    sim.step(10)
    t_set = sim.time
    target = PartTarget(np.array(LEFT_HAND.parking), np.array([0.1, 0.0, 0.0]))
    sim.set_target("person_left_hand", target)
    sim.step(10)
    sim.person.apply_wrenches(sim.time)
    moved = target.position + target.velocity * (sim.time - t_set)
    assert sim.time > t_set > 0.0
    force, _ = _expected_wrench(sim, LEFT_HAND, moved, target.velocity, 0.0)
    b = sim.person.part_body[LEFT_HAND.name]
    np.testing.assert_allclose(sim.data.xfrc_applied[b, :3], force, atol=1e-9)


@pytest.mark.parametrize("restart", ["reset", "settle"])
def test_restart_restarts_the_targets_clock(restart: str) -> None:
    """After a reset or a settling (time back to 0) a moving target pulls from where it was set,
    not from where it would have been had its clock kept running."""
    sim = _quiet_sim()
    sim.step(20)
    target = PartTarget(np.array(LEFT_HAND.parking), np.array([0.5, 0.0, 0.0]))
    sim.set_target("person_left_hand", target)
    if restart == "reset":
        sim.reset()
    else:
        sim.settle(0.0)
    sim.person.apply_wrenches(sim.time)
    assert sim.time == 0.0
    force, _ = _expected_wrench(sim, LEFT_HAND, target.position, target.velocity, 0.0)
    b = sim.person.part_body[LEFT_HAND.name]
    np.testing.assert_allclose(sim.data.xfrc_applied[b, :3], force, atol=1e-9)


@given(st.floats(0.0, 1.0))
def test_minimum_jerk_rate_is_its_derivative(x: float) -> None:
    duration, h = 2.0, 1e-6
    lo, hi = max(x - h, 0.0), min(x + h, 1.0)
    numeric = (minimum_jerk(hi) - minimum_jerk(lo)) / ((hi - lo) * duration) if hi > lo else 0.0
    assert minimum_jerk_rate(x, duration) == pytest.approx(numeric, abs=1e-5)
    assert -1e-12 <= minimum_jerk(x) <= 1.0 + 1e-12


def test_refuses_a_timestep_that_diverges() -> None:
    with pytest.raises(ValueError, match="timestep"):
        SimConfig(timestep=0.01)


def test_coarser_step_keeps_the_contact_force() -> None:
    """The lock-step runner's 5 ms step reproduces the 2 ms resting contact (same settling)."""
    forces = []
    for dt in (0.002, 0.005):
        sim = _quiet_sim(timestep=dt)
        start_scenario(sim, SCENARIOS["waltz"])
        forces.append(np.mean(_hold_robot(sim, 0.5)))
    assert forces[1] == pytest.approx(forces[0], rel=0.03)


def test_the_torso_has_no_gap_a_link_could_enter() -> None:
    """Waist, abdomen and chest cover the trunk's height with no gap wider than 2 cm (the
    UR16e's thinnest links, the wrists, are ≈ 9 cm across): the vertical extents of its geoms
    (centre ± radius). With a 19 cm gap between waist and chest a robot link the partner walked
    into was squeezed between the two capsules of one rigid body (kilonewtons on a standing
    robot). (The neck, between chest and head, is above every arm link in the scenarios.)"""
    trunk = [g for g in TORSO.geoms if g.name != "person_head"]
    spans = sorted((g.pos[2] - g.size[0], g.pos[2] + g.size[0]) for g in trunk)
    top = spans[0][1]
    for low, high in spans[1:]:
        assert low - top < 0.02, f"gap in the torso from {top:.3f} to {low:.3f} m"
        top = max(top, high)


def test_the_abdomen_changes_nothing_but_collisions() -> None:
    """The abdomen is massless: the torso's mass (and so its dynamics) is what it was."""
    sim = _quiet_sim()
    body = sim.model.body("person_torso").id
    tissue = TORSO.tissue
    assert tissue is not None
    assert sim.model.body_mass[body] == pytest.approx(TORSO.mass - tissue.mass)
    assert sim.model.geom_rgba[sim.model.geom("person_abdomen").id][3] == 1.0
