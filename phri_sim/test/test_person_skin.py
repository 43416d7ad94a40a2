"""Skin footprint and the person's physics: forces come from contact, totals match, locality."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from phri_description.description import robot_description
from phri_sim.scenarios.catalogue import Q_HOME, press_geometry
from phri_sim.world.person_body import LEFT_HAND, PartTarget
from phri_sim.world.simulation import SimConfig, Simulation
from phri_sim.world.skin_footprint import (
    CapsuleShape,
    SkinConfig,
    SphereShape,
    distribute,
    footprint_weights,
    layout_for_patch,
)
from skin_driver.layout import cylindrical_patch


def test_layout_is_skin_driver_generator_output() -> None:
    patch = robot_description().patch("left_forearm")
    ours = layout_for_patch(patch)
    theirs = cylindrical_patch(patch.name, patch.link, patch.radius, patch.axial_range,
                               angle_range=patch.angular_range, axis_point=patch.point,
                               axis=patch.axis, reference=patch.zero_direction)
    np.testing.assert_array_equal(ours.positions, theirs.positions)
    # Taxels lie on the link's collision cylinder, normals radially outward.
    radial = ours.positions - np.array(patch.point)
    radial[:, 0] = 0.0
    np.testing.assert_allclose(np.linalg.norm(radial, axis=1), patch.radius, atol=1e-12)


def test_signed_distances_analytic() -> None:
    pts = np.array([[0.0, 0.0, 2.0], [0.0, 0.0, 0.5], [3.0, 0.0, 0.0]])
    sphere = SphereShape(np.zeros(3), 1.0)
    np.testing.assert_allclose(sphere.signed_distance(pts), [1.0, -0.5, 2.0])
    capsule = CapsuleShape(np.array([0.0, 0.0, -1.0]), np.array([0.0, 0.0, 1.0]), 0.5)
    np.testing.assert_allclose(capsule.signed_distance(pts), [0.5, -0.5, 2.5])


@given(st.floats(0.0, 100.0),
       st.lists(st.one_of(st.just(0.0), st.floats(1e-6, 0.01)), min_size=1, max_size=50))
def test_distribute_conserves_total(total: float, weights: list[float]) -> None:
    w = np.array(weights)
    f = distribute(total, w)
    assert np.all(f >= 0.0)
    if w.sum() > 0:
        assert f.sum() == pytest.approx(total, rel=1e-9, abs=1e-12)
    else:
        assert f.sum() == 0.0


def test_tangent_sphere_lights_a_disc_not_one_taxel() -> None:
    """A point contact (sphere just touching) spreads over the ellipse where the gap is < h:
    semi-axes √(2 R h) along the link (flat) and √(2 R_eff h) around it (curved)."""
    patch = robot_description().patch("right_forearm")
    layout = layout_for_patch(patch)
    touch = patch.surface_point(0.18, 0.0)
    normal = patch.normal(0.0)
    sphere = SphereShape(touch + normal * 0.045, 0.045)
    w = footprint_weights(layout.positions, sphere, 0.004)
    lit = int(np.count_nonzero(w))
    r_eff = 0.045 * patch.radius / (0.045 + patch.radius)
    expected_area = np.pi * 2 * 0.004 * np.sqrt(0.045 * r_eff)
    assert lit >= 6
    assert lit == pytest.approx(expected_area / 0.0075**2, rel=0.5)


def _pressed_sim(noise: float = 0.0) -> tuple[Simulation, PartTarget]:
    sim = Simulation(SimConfig(skin=SkinConfig(noise_std=noise)))
    # Frictionless hand: at rest its whole spring force then goes through the (normal) contact.
    # (MuJoCo mixes friction by the maximum, so both geoms are made frictionless.)
    sim.model.geom_friction[sim.model.geom("person_right_hand").id] = 0.0
    sim.model.geom_friction[sim.model.geom("right_forearm_tube").id] = 0.0
    sim.reset(np.array(Q_HOME))
    point, normal, _ = press_geometry(sim, "right_forearm", 0.18, np.array([0.0, 0.0, 1.0]))
    touching = point + normal * 0.045
    target = PartTarget(touching - normal * 0.03, np.zeros(3))  # 0.03 m × 400 N/m = 12 N
    sim.set_target("person_right_hand", PartTarget(touching + 0.01 * normal, np.zeros(3)),
                   teleport=True)
    sim.set_target("person_right_hand", target)
    for _ in range(15):  # 1.5 s: settle on the spring while the robot holds still
        sim.command("base", np.zeros(3))
        sim.command("left", np.zeros(6))
        sim.command("right", np.zeros(6))
        sim.step(50)
    return sim, target


def test_taxel_total_equals_spring_force_within_2_percent() -> None:
    """Physics check: at rest the hand's spring force K·(target − hand) is balanced by the
    contact, and the taxels' total equals it."""
    sim, target = _pressed_sim()
    hand, _ = sim.part_pose("person_right_hand")
    spring = LEFT_HAND.stiffness * (target.position - hand)
    forces = sim.skins.forces(noise=False)["right_forearm"]
    assert np.linalg.norm(spring) == pytest.approx(12.0, rel=0.1)
    assert forces.sum() == pytest.approx(np.linalg.norm(spring), rel=0.02)
    # The resultant of the taxels' normal forces on the link is the spring's push.
    rot, _ = sim.link_pose("right_forearm_link")
    layout = sim.patches["right_forearm"].layout
    resultant = rot @ -(forces[:, None] * layout.normals).sum(axis=0)
    np.testing.assert_allclose(resultant, spring, atol=0.03 * np.linalg.norm(spring))
    truth = sim.ground_truth()["right_forearm_link"]
    np.testing.assert_allclose(truth.force_world, spring, atol=0.02 * np.linalg.norm(spring))


def test_pressed_link_reports_taxels_where_touched_and_nowhere_else() -> None:
    sim, _ = _pressed_sim(noise=0.005)
    frames = sim.skins.forces()
    threshold = 0.05  # contact estimation's default σ_t
    for name, forces in frames.items():
        lit = forces > threshold
        if name != "right_forearm":
            assert not lit.any(), f"{name} lit without a touch"
            continue
        assert lit.sum() >= 6
        hand, _ = sim.part_pose("person_right_hand")
        rot, pos = sim.link_pose("right_forearm_link")
        layout = sim.patches[name].layout
        world = layout.positions[lit] @ rot.T + pos
        # Every lit taxel lies under the hand: within hand radius + footprint reach.
        assert np.max(np.linalg.norm(world - hand, axis=1)) < 0.045 + 0.03
        centre = layout.positions[lit].mean(axis=0)
        truth = sim.ground_truth()["right_forearm_link"].center_link
        assert np.linalg.norm(centre - truth) < 0.005


def _hold(sim: Simulation, right: np.ndarray, steps: int) -> None:
    for _ in range(steps):
        sim.command("base", np.zeros(3))
        sim.command("left", np.zeros(6))
        sim.command("right", right)
        sim.step(5)


def test_robot_yields_and_force_falls() -> None:
    """Moving the forearm away from the hand pressing on it lowers the contact force: the force
    comes from the physics, not from a script."""
    sim, _ = _pressed_sim()
    before = sim.ground_truth()["right_forearm_link"].normal_force
    z0 = sim.link_pose("right_forearm_link")[1][2]
    # Which sign of the shoulder pan lowers the forearm (away from a hand pressing down)?
    probe, _ = _pressed_sim()
    _hold(probe, np.array([0.05, 0, 0, 0, 0, 0]), 2)
    sign = 1.0 if probe.link_pose("right_forearm_link")[1][2] < z0 else -1.0
    _hold(sim, np.array([0.1 * sign, 0, 0, 0, 0, 0]), 30)
    after = sim.ground_truth()["right_forearm_link"].normal_force
    assert before > 10.0
    assert after < 0.5 * before


def test_body_twist_is_followed_in_the_body_frame() -> None:
    """The ideal plant (servos at once): the body-frame mapping alone, without the realistic
    drives' latency and ramps (test_actuators.py)."""
    sim = Simulation(SimConfig(skin=SkinConfig(noise_std=0.0), plant="ideal"))
    q = np.array(Q_HOME)
    q[2] = np.pi / 2  # facing +y
    sim.reset(q)
    for _ in range(100):
        sim.command("base", np.array([0.1, 0.0, 0.0]))
        sim.step(5)
    x, y = sim.q[0], sim.q[1]
    assert abs(x) < 0.005
    assert y == pytest.approx(0.1, abs=0.01)
    np.testing.assert_allclose(sim.base_twist(), [0.1, 0.0, 0.0], atol=2e-3)


@pytest.mark.parametrize("yaw", [0.4, -2.0])
def test_sideways_twist_turns_with_the_yaw(yaw: float) -> None:
    """(v_x, v_y) in the base frame moves the base along R(yaw) (v_x, v_y) in the world."""
    sim = Simulation(SimConfig(skin=SkinConfig(noise_std=0.0)))
    q = np.array(Q_HOME)
    q[2] = yaw
    sim.reset(q)
    twist = np.array([0.04, -0.08, 0.0])
    for _ in range(100):
        sim.command("base", twist)
        sim.step(5)
    c, s = np.cos(yaw), np.sin(yaw)
    world = np.array([c * twist[0] - s * twist[1], s * twist[0] + c * twist[1]])
    np.testing.assert_allclose(sim.qd[:2], world, atol=2e-3)
    np.testing.assert_allclose(sim.base_twist(), twist, atol=2e-3)


def test_reset_restarts_the_noise_from_the_seed() -> None:
    sim = Simulation(SimConfig(seed=7))
    first = sim.skins.forces()
    sim.step(2)
    sim.skins.forces()
    sim.reset()
    again = sim.skins.forces()
    for patch, forces in first.items():
        np.testing.assert_array_equal(again[patch], forces)


@settings(max_examples=5, deadline=None)
@given(st.integers(0, 1000))
def test_same_seed_same_noise(seed: int) -> None:
    a = Simulation(SimConfig(seed=seed))
    b = Simulation(SimConfig(seed=seed))
    for _ in range(3):
        a.step(2)
        b.step(2)
        fa, fb = a.skins.forces(), b.skins.forces()
        for k in fa:
            np.testing.assert_array_equal(fa[k], fb[k])
