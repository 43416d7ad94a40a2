"""Contact safety: the graded response to the contact force against the body region's
limit, contact-gated desired force with a bounded regain, in the pure pieces, in one task and in
closed loop with a compliant hand."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from wbc_rotations import exp_rotvec

from phri_common.iso15066 import SKIN_LINK_REGIONS
from phri_common.records import ContactState
from phri_description.description import SKIN_LINKS
from wholebody_controller.config import WALTZ, AdmittanceGains, ControllerConfig, LinkTaskConfig
from wholebody_controller.contact_safety import (
    Safety,
    SafetyConfig,
    approach_scale,
    limit_approach,
    yield_scale,
    yield_speed_of,
)
from wholebody_controller.controller import KinematicsModel, WholeBodyController
from wholebody_controller.task_rows import N_STATE, link_params
from wholebody_controller.task_step import guard_update, regain_update
from wholebody_controller.tasks import ContactTask

LINK = "left_forearm_link"
ROT = exp_rotvec(np.array([0.3, -0.5, 1.1]))
POS = np.array([0.4, 0.2, 1.1])
CENTER = np.array([-0.2, 0.01, 0.05])


# -- pure pieces ----------------------------------------------------------------------------------
def test_approach_scale_is_one_then_linear_then_zero() -> None:
    assert approach_scale(0.0, 110.0, 0.5) == 1.0
    assert approach_scale(55.0, 110.0, 0.5) == 1.0
    assert approach_scale(82.5, 110.0, 0.5) == pytest.approx(0.5)
    assert approach_scale(110.0, 110.0, 0.5) == 0.0
    assert approach_scale(1e9, 110.0, 0.5) == 0.0


unit = st.lists(st.floats(-1.0, 1.0), min_size=3, max_size=3).filter(
    lambda v: math.hypot(*v) > 1e-3)


@given(v=st.lists(st.floats(-2.0, 2.0), min_size=3, max_size=3), n=unit,
       s=st.floats(0.0, 1.0))
def test_limit_approach_only_shrinks_the_part_towards_the_contact(
        v: list[float], n: list[float], s: float) -> None:
    normal = np.array(n) / np.linalg.norm(n)
    out = np.array(limit_approach(tuple(v), tuple(normal), s))  # type: ignore[arg-type]
    along, along_out = float(np.dot(v, normal)), float(out @ normal)
    tangent, tangent_out = np.array(v) - along * normal, out - along_out * normal
    np.testing.assert_allclose(tangent_out, tangent, atol=1e-12)
    if along >= 0.0:
        assert along_out == pytest.approx(along)
    else:
        assert along_out == pytest.approx(s * along, abs=1e-12)


def _rows(link: LinkTaskConfig, safety: SafetyConfig) -> tuple[np.ndarray, np.ndarray]:
    """A fresh state row and the parameter row of ``link`` (100 Hz)."""
    return np.zeros(N_STATE), link_params(link, ControllerConfig(links=(link,), safety=safety))


def test_force_guard_yields_at_the_limit_with_hysteresis() -> None:
    s, p = _rows(LinkTaskConfig(LINK, force_limit=110.0, transient_force_limit=220.0),
                 SafetyConfig(fade_start=0.5, reset_ratio=0.5))
    task = ContactTask(LinkTaskConfig(LINK), state=s, params=p)
    assert guard_update(s, p, 50.0) == 1.0 and not task.yielding
    assert 0.0 < guard_update(s, p, 100.0) < 1.0 and not task.yielding
    assert guard_update(s, p, 110.0) == 0.0 and task.yielding
    assert guard_update(s, p, 60.0) == 0.0 and task.yielding  # above r·F = 55 N: still yielding
    assert guard_update(s, p, 54.0) == 1.0 and not task.yielding
    assert task.peak_force == 110.0 and not task.transient_exceeded
    guard_update(s, p, 230.0)
    assert task.transient_exceeded


def test_regain_budget_bounds_distance_and_time() -> None:
    s, p = _rows(LinkTaskConfig(LINK), SafetyConfig(regain_distance=0.15, regain_time=2.0))
    assert regain_update(s, p, False, 0.1) and regain_update(s, p, False, 0.04)
    assert not regain_update(s, p, False, 0.02)  # 0.16 m > 0.15 m
    assert not regain_update(s, p, False, 0.0)  # latched until a touch
    assert regain_update(s, p, True, 0.0)
    assert all(regain_update(s, p, False, 0.0) for _ in range(200))  # 2.00 s at 100 Hz
    assert not regain_update(s, p, False, 0.0)


def test_safety_config_refusals_name_the_field() -> None:
    with pytest.raises(ValueError, match=r"parameter .force_fade_start. refused value 1\.0"):
        SafetyConfig(fade_start=1.0)
    with pytest.raises(ValueError, match="force_limit"):
        LinkTaskConfig(LINK, force_limit=300.0, transient_force_limit=200.0)


def test_every_skin_link_of_the_description_has_a_body_region() -> None:
    assert set(SKIN_LINK_REGIONS) == set(SKIN_LINKS)


def test_default_limits_are_the_regions_of_iso_ts_15066() -> None:
    assert (LinkTaskConfig(LINK).force_limit, LinkTaskConfig(LINK).transient_force_limit) == (
        110.0, 220.0)  # abdomen: the partner's waist
    assert LinkTaskConfig("right_forearm_link").force_limit == 140.0  # hands


# -- one task -------------------------------------------------------------------------------------
def make_task(**kwargs: object) -> ContactTask:
    return ContactTask(LinkTaskConfig(LINK, **kwargs))  # type: ignore[arg-type]


def press(force_world: np.ndarray, k: int) -> ContactState:
    return ContactState(LINK, k, True, CENTER, ROT.T @ force_world, np.zeros(3), CENTER - 0.01,
                        CENTER + 0.01, 10)


def step(task: ContactTask, state: ContactState, pos: np.ndarray = POS) -> object:
    return task.step(state, ROT.ravel().tolist(), pos.tolist(), 0.0)


def test_a_push_at_the_limit_makes_the_link_yield_along_the_push() -> None:
    task = make_task()
    push = np.array([0.0, 0.0, -1.0])  # the person pushes the link down
    out = step(task, press(50.0 * push, 0))
    assert out.safety is Safety.OK  # type: ignore[attr-defined]
    out = step(task, press(110.0 * push, 1))
    assert out.safety is Safety.YIELDING and out.psi == 1.0  # type: ignore[attr-defined]
    np.testing.assert_allclose(out.target, [0, 0, -0.15, 0, 0, 0], atol=1e-12)  # type: ignore
    out = step(task, press(60.0 * push, 2))
    assert out.safety is Safety.YIELDING  # type: ignore[attr-defined]
    out = step(task, press(40.0 * push, 3))
    assert out.safety is Safety.OK  # type: ignore[attr-defined]


def test_desired_force_acts_only_in_contact_within_the_regain_budget() -> None:
    task = make_task(priority_lock=1.0, desired_force=(0.0, -10.0, 0.0), admittance=WALTZ)
    touched = press(np.array([0.0, 10.0, 0.0]), 0)
    out = step(task, touched)
    assert out.wrench[1] == pytest.approx(0.0, abs=1e-9)  # type: ignore[attr-defined]
    # Contact lost: the desired force keeps acting while the link has moved < 0.15 m.
    pos = POS.copy()
    for k in range(1, 300):
        pos = pos + np.array([0.0, -0.002, 0.0])  # the link follows the force at 0.2 m/s
        out = step(task, ContactState.no_contact(LINK, k), pos)
        if out.safety is Safety.CONTACT_LOST:  # type: ignore[attr-defined]
            break
    travelled = float(np.linalg.norm(pos - POS))
    assert 0.14 < travelled <= 0.152, travelled
    assert out.wrench[1] == 0.0  # type: ignore[attr-defined]
    # A new touch re-arms it.
    out = step(task, touched, pos)
    assert out.safety is Safety.OK and out.wrench[1] < -9.0 + 10.0  # type: ignore[attr-defined]


@pytest.mark.parametrize(("force", "speed"), [
    (110.5, 0.15 + 0.5 / 110.0 * 0.85), (137.5, 0.15 + 0.25 * 0.85),
    (165.0, 0.15 + 0.5 * 0.85), (220.0, 1.0), (2000.0, 1.0)])
def test_the_yield_speed_grows_with_the_excess_over_the_limit(force: float, speed: float) -> None:
    """yield_speed (0.15 m/s) at F = 110 N, linear in the excess, yield_speed_max (1 m/s) from
    (1 + yield_full_excess)·F = 220 N on; the output row carries the excess scale σ."""
    task = make_task()
    push = np.array([0.6, 0.0, -0.8])
    out = step(task, press(force * push, 0))
    assert out.safety is Safety.YIELDING  # type: ignore[attr-defined]
    np.testing.assert_allclose(out.target[0:3], speed * push, atol=1e-12)  # type: ignore
    assert task.yield_excess == pytest.approx(min((force - 110.0) / 110.0, 1.0))


def test_the_bounds_stay_open_until_the_push_is_over() -> None:
    """The yield's opening (σ at its largest) is held while the force stays above the fade start
    (a partner still pushing at 70 N after a 220 N shove is not pushed back by the band), and
    closes once it falls to it."""
    task = make_task()
    push = np.array([0.0, 0.0, -1.0])
    for k, (force, opened) in enumerate([(165.0, 0.5), (220.0, 1.0), (120.0, 1.0), (70.0, 1.0),
                                         (56.0, 1.0), (50.0, 0.0), (120.0, 0.0909)]):
        step(task, press(force * push, k))
        assert task.yield_excess == pytest.approx(opened, abs=1e-4), (force, opened)


def test_yield_scale_and_speed() -> None:
    assert yield_scale(100.0, 110.0, 1.0) == 0.0 and yield_scale(165.0, 110.0, 1.0) == 0.5
    assert yield_scale(165.0, 110.0, 0.25) == 1.0
    assert yield_speed_of(0.5, 0.15, 1.0) == pytest.approx(0.575)
    assert yield_speed_of(1.0, 0.15, 0.05) == 0.15  # never below yield_speed


# -- closed loop with a compliant hand ----------------------------------------------------------
def hand_push(kin: KinematicsModel, force_limit: float) -> tuple[list[float], list[Safety]]:
    """A hand whose target goes 0.4 m into the left forearm at 0.12 m/s through a 20 kN/m spring
    (2 kN and more on a rigid link), then withdraws; an admittance too stiff (D = 3000 N·s/m) to
    give way fast enough on its own. Returns the contact force and the safety state per cycle."""
    gains = AdmittanceGains(WALTZ.inertia, (3000.0,) * 3 + WALTZ.damping[3:], WALTZ.stiffness)
    link = LinkTaskConfig(LINK, gains, force_limit=force_limit,
                          transient_force_limit=max(220.0, force_limit))
    ctl = WholeBodyController(kin, ControllerConfig(links=(link,)))
    q = np.array([0.0, 0.0, 0.0, 0.3, -1.2, 1.5, -1.0, -1.57, 0.0,
                  -0.3, -1.9, -1.5, -1.0, 1.57, 0.0])
    kin.update(q)
    rot, pos = kin.link_pose(LINK)
    surface = rot @ CENTER + pos
    direction = np.array([0.0, 1.0, 0.0])
    forces, states = [], []
    for k in range(600):
        kin.update(q)
        rot, pos = kin.link_pose(LINK)
        anchor = surface + direction * min(0.12 * k * 0.01, 0.4) if k <= 450 else surface
        force = max(0.0, 20_000.0 * float((anchor - (rot @ CENTER + pos)) @ direction))
        forces.append(force)
        contacts = {}
        if force > 0.0:
            contacts[LINK] = ContactState(LINK, k, True, CENTER, rot.T @ (force * direction),
                                          np.zeros(3), CENTER - 0.01, CENTER + 0.01, 10)
        res = ctl.step(q, contacts)
        states.append(res.tasks[0].safety)
        q = q + 0.01 * res.qdot
    return forces, states


def test_a_hand_pushing_to_2_kN_is_yielded_to_below_the_transient_limit(
        kin: KinematicsModel) -> None:
    forces, states = hand_push(kin, 110.0)
    assert max(forces) >= 110.0  # the limit was reached: the test exercises the yield
    assert max(forces) < 220.0, max(forces)
    assert Safety.YIELDING in states and states[-1] is Safety.OK
    # Baseline: the same robot without a usable limit is pressed far beyond it.
    unguarded, _ = hand_push(kin, 1e5)
    assert max(unguarded) > 400.0, max(unguarded)


@settings(max_examples=30, deadline=None)
@given(st.lists(st.floats(0.0, 5000.0), min_size=5, max_size=40))
def test_never_commands_towards_a_contact_at_or_above_the_limit(forces: list[float]) -> None:
    task = make_task()
    push = np.array([0.3, -0.4, -0.866])
    push /= np.linalg.norm(push)
    for k, f in enumerate(forces):
        out = step(task, press(f * push, k))
        if task.yielding:
            assert float(np.dot(out.target[0:3], push)) > 0.0  # type: ignore[attr-defined]


# -- the whole body while yielding ----------------------------------------------------------------
def _band_robot(kin: KinematicsModel, **safety: float) -> tuple[WholeBodyController, np.ndarray]:
    """The left forearm task on the real robot, arms held in a ±0.03 rad q_dance band, Table
    II's 0.15 velocity limit, the default actuator limits; q at the band's centre."""
    from wholebody_controller.config import dance_ranges

    q = np.array([0.0, 0.0, 0.0, 0.3, -1.2, 1.5, -1.0, -1.57, 0.0,
                  -0.3, -1.9, -1.5, -1.0, 1.57, 0.0])
    config = ControllerConfig(links=(LinkTaskConfig(LINK, WALTZ),),
                              joint_ranges=dance_ranges(kin.joint_names[3:], q[3:], 0.03),
                              safety=SafetyConfig(**safety))  # type: ignore[arg-type]
    return WholeBodyController(kin, config), q


def _yield_run(kin: KinematicsModel, force: float, periods: int = 60) -> tuple[np.ndarray, ...]:
    """``periods`` cycles of a push of ``force`` [N] on the left forearm (world −y) with the
    robot moving as commanded; the commands and the configurations."""
    ctl, q = _band_robot(kin)
    commands, configs = [], [q.copy()]
    for k in range(periods):
        kin.update(q)
        rot, _ = kin.link_pose(LINK)
        state = ContactState(LINK, k, True, CENTER, rot.T @ np.array([0.0, -force, 0.0]),
                             np.zeros(3), CENTER - 0.01, CENTER + 0.01, 10)
        res = ctl.step(q, {LINK: state})
        commands.append(res.command.copy())
        q = q + 0.01 * res.qdot
        configs.append(q.copy())
    return np.array(commands), np.array(configs)


def test_a_yield_above_the_limit_opens_the_band_and_the_speed_limit_within_the_actuators(
        kin: KinematicsModel) -> None:
    """At F the whole body keeps Table II's 0.15 and the q_dance band; at the full excess (2F)
    the arm leaves the band (by up to yield_joint_range) and its joints exceed 0.15 up to their
    actuator limits, the base keeps its bounds (a fast base turn sweeps the other arm through
    the partner), and every command stays within the rated acceleration × dt of the previous
    one."""
    ctl, _ = _band_robot(kin)
    at_limit, q_at = _yield_run(kin, 110.0)
    assert np.max(np.abs(at_limit)) <= 0.15 + 1e-9
    assert np.max(np.abs(q_at[:, 3:] - q_at[0, 3:])) <= 0.03 + 0.15 * 0.01 + 1e-9
    full, q_full = _yield_run(kin, 250.0)
    assert np.max(np.abs(full[:, 3:])) > 0.3  # the arm: beyond Table II's 0.15
    assert np.max(np.abs(full[:, :3])) <= 0.15 + 1e-9  # the base keeps its bounds
    assert np.max(np.abs(q_full[:, 3:] - q_full[0, 3:])) > 0.06  # out of the ±0.03 band
    assert np.max(np.abs(q_full[:, 3:] - q_full[0, 3:])) <= 0.03 + 0.3 + 0.05
    actuator = ctl.limits[7]
    assert np.all(np.abs(full) <= actuator + 1e-9)
    steps = np.diff(np.vstack([np.zeros(15), full]), axis=0)
    assert np.all(np.abs(steps) <= ctl.limits[4] + 1e-9)
