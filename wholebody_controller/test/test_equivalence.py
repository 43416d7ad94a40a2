"""The production control step against the independent numpy reference ``wbc_reference.py``
on random inputs: every output within 1e-9 (the command within 1e-7, ``wbc_tolerances``).

The reference covers everything that ships (contact safety, Algorithm 1, Ω_d with its window
and hysteresis, the lead moment and leash, (10)–(23)); it runs beside the Python step on an
independent D-H robot (``wbc_fake_kinematics``) and beside the compiled step on the real robot.
A failure prints the example (hypothesis) and its ``@reproduce_failure`` blob; the examples of
the default profile are derandomized, ``--hypothesis-profile=deep`` draws many more
(``docs/wholebody_controller.md``, "Tests").

Also the pieces on their own: the admittance step against ``Φ s + Γ w``, and
the QP assembly against the reference's (the SO(3) maps are checked against scipy in
``test_so3.py``).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from wbc_fake_kinematics import FakeKinematics
from wbc_reference import RefController, ref_build_qp, ref_velocity_bounds
from wbc_rotations import exp_rotvec
from wbc_scenarios import configs, touch_sequence
from wbc_tolerances import GAINS, QP_TOL, TOL, close

from phri_common.records import ContactState
from phri_common.testing import examples
from wholebody_controller.admittance import admittance_step, discretise, transition
from wholebody_controller.config import (
    CONTACT_CENTRING,
    SKIN_LINKS,
    WALTZ,
    WHOLE_BODY,
    ControllerConfig,
    LinkTaskConfig,
    dance_ranges,
)
from wholebody_controller.contact_safety import Safety
from wholebody_controller.contact_task import Phase
from wholebody_controller.controller import StepResult, WholeBodyController
from wholebody_controller.kinematics import RobotKinematics
from wholebody_controller.qp import build_qp, velocity_bounds

Q0 = np.array([0.2, -0.1, 0.4, 0.3, -1.2, 1.5, -1.0, -1.57, 0.0,
               -0.3, 1.2, -1.5, 1.0, 1.57, 0.0])


def assert_same_step(fast: StepResult, ref: object) -> None:
    close(fast.command, ref.command, "command", QP_TOL)  # type: ignore[attr-defined]
    close(fast.qdot, ref.qdot, "qdot", QP_TOL)  # type: ignore[attr-defined]
    for name in ("hessian", "gradient"):
        close(getattr(fast.problem, name), getattr(ref.problem, name), name)  # type: ignore
    # The bounds hold the acceleration window around the previous command, the previous QP's
    # answer: they agree as closely as that answer does.
    for name in ("lower", "upper"):
        close(getattr(fast.problem, name), getattr(ref.problem, name), name, QP_TOL)  # type: ignore
    for i, (a, b) in enumerate(zip(fast.tasks, ref.tasks, strict=True)):  # type: ignore
        assert (a.phase, a.in_contact, a.safety) == (b.phase, b.in_contact, b.safety), i
        close([a.psi, a.psi_raw], [b.psi, b.psi_raw], f"psi {i}")
        for name in ("point", "target", "control_velocity", "wrench", "track_force",
                     "deflection", "deflection_velocity"):
            close(getattr(a, name), getattr(b, name), f"{name} {i}")
    close(np.concatenate(fast.tracking_errors),  # type: ignore[attr-defined]
          np.concatenate(ref.tracking_errors), "tracking errors", QP_TOL)


vec3 = st.lists(st.floats(-1.0, 1.0), min_size=3, max_size=3).map(np.array)


@st.composite
def scenarios(draw: st.DrawFn) -> tuple[ControllerConfig, list[dict[str, ContactState]]]:
    links = []
    for link in SKIN_LINKS:
        lock = draw(st.sampled_from([None, None, 0.3, 1.0]))
        force = tuple(draw(st.lists(st.sampled_from([0.0, 0.0, -10.0, 4.0]), min_size=3,
                                    max_size=3)))
        reference = None
        if draw(st.integers(0, 4)) == 0:
            rot = exp_rotvec(draw(vec3))
            reference = (*rot.ravel().tolist(), *draw(vec3).tolist())
        region = None
        if draw(st.integers(0, 4)) == 0:
            region = ((-0.3, -0.1, -0.1), (0.0, 0.1, 0.1))
        links.append(LinkTaskConfig(link, GAINS[draw(st.integers(0, len(GAINS) - 1))],
                                    priority_lock=lock, desired_force=force,  # type: ignore
                                    reference=reference, desired_region=region))
    kin = FakeKinematics()
    config = ControllerConfig(
        links=tuple(links),
        k_eta=draw(st.sampled_from([0.0, 200.0])),
        force_deadband=draw(st.sampled_from([0.0, 0.5, 3.0])),
        torque_deadband=draw(st.sampled_from([0.0, 0.01, 0.2])),
        turn_force_limit=draw(st.sampled_from([0.0, 2.0, 20.0])),
        b=draw(st.sampled_from([4.0, 40.0])),
        rate_hz=draw(st.sampled_from([100.0, 500.0])),
        joint_ranges=dance_ranges(kin.joint_names[3:], list(Q0[3:]), 0.1)
        if draw(st.booleans()) else (),
    )
    steps: list[dict[str, ContactState]] = []
    for _ in range(draw(st.integers(2, 5))):
        length = draw(st.integers(3, 15))
        touched = {}
        for link in SKIN_LINKS:
            if draw(st.booleans()):
                touched[link] = (30.0 * draw(vec3), 1.2 * draw(vec3),
                                 np.array([-0.15, 0.0, 0.05]) + 0.1 * draw(vec3),
                                 0.03 * np.abs(draw(vec3)), 0.004 * draw(vec3))
        for k in range(length):
            step = {}
            for link, (f, t, c, w, slide) in touched.items():
                centre = c + k * slide
                step[link] = ContactState(link, k, True, centre, f, t, centre - w, centre + w, 9)
            steps.append(step)
    return config, steps


def run_against_reference(fast: WholeBodyController, ref: RefController, q0: np.ndarray,
                          sequence: list[dict[str, ContactState]]) -> list[StepResult]:
    """Step both through ``sequence`` from ``q0``, comparing every step; the production step's
    results."""
    q, results = q0.copy(), []
    for k, contacts in enumerate(sequence):
        a, b = fast.step(q, contacts), ref.step(q.copy(), contacts)
        try:
            assert_same_step(a, b)
        except AssertionError as err:
            raise AssertionError(f"step {k}: {err}") from None
        results.append(a)
        # Same motion on both sides keeps the comparison exact over the whole sequence.
        q = q + fast.config.dt * a.qdot
    return results


@settings(max_examples=examples(3), suppress_health_check=[HealthCheck.too_slow])
@given(scenarios(), st.sampled_from(["daqp", "osqp"]))
def test_fast_step_equals_reference(
    case: tuple[ControllerConfig, list[dict[str, ContactState]]], solver: str
) -> None:
    config, sequence = case
    config = replace(config, solver=solver)
    run_against_reference(WholeBodyController(FakeKinematics(), config),
                          RefController(FakeKinematics(), config), Q0, sequence)


@settings(max_examples=examples(1), suppress_health_check=[HealthCheck.too_slow])
@given(configs(), st.integers(0, 2**31 - 1), st.sampled_from([5.0, 40.0]),
       st.sampled_from(["fake", "robot"]))
def test_step_with_safety_lead_and_region_rules_equals_reference(
        config: ControllerConfig, seed: int, force_scale: float, robot: str) -> None:
    """Every rule around the paper's equations against the reference: safety states, regain
    budget, lead moment and leash, Ω_d window and hysteresis — on the independent D-H robot
    (the Python step) and on the real one (the compiled step)."""
    sequence = touch_sequence(np.random.default_rng(seed), 80, force_scale, config.dt)
    kinematics = FakeKinematics if robot == "fake" else RobotKinematics
    run_against_reference(WholeBodyController(kinematics(), config),
                          RefController(kinematics(), config), Q0, sequence)


def test_desired_force_without_contact_stops_after_the_regain_distance() -> None:
    """The falsifying example hypothesis found (``shared/repro/equivalence_falsifying_example
    .txt``): the left forearm, never touched, carries a 4 N desired force while a 19 N touch on
    the upper arm slides and stops. The robot's motion carries the forearm 0.15 m (the regain
    distance) in 48 periods: its task must then stop (contact lost) — the old reference had no
    contact safety and kept pushing, 0.08 rad/s apart from the production step. (Found before
    the commands had acceleration bounds: run without them, as it was found.)"""
    reference = (1.0, -6.957587728774077e-55, 1.334996053504775e-54, -6.957587728774077e-55,
                 0.5728002514355479, 0.8196949871478861, -1.334996053504775e-54,
                 -0.8196949871478861, 0.5728002514355479, 0.22604997832140739,
                 -0.4044630622503743, -0.9545119926274008)
    forearm_ref = (0.7347671663923288, -0.6783193997722825, -5.5536998514144894e-05,
                   0.6783193997722825, 0.7347671681702954, -2.1715780784352928e-05,
                   5.5536998514144894e-05, -2.1715780784352928e-05, 0.9999999982220333,
                   -2.220446049250313e-16, -0.4974022627774438, 0.9504249869850798)
    box = ((-0.3, -0.1, -0.1), (0.0, 0.1, 0.1))
    links = (LinkTaskConfig("left_upper_arm_link", WHOLE_BODY, reference=reference),
             LinkTaskConfig("left_forearm_link", WALTZ, desired_force=(4.0, 0.0, 0.0),
                            reference=forearm_ref, desired_region=box),
             LinkTaskConfig("right_forearm_link", CONTACT_CENTRING, desired_region=box))
    config = ControllerConfig(links=links, b=40.0, acceleration_limits=(1e3,) * 15)
    link = "left_upper_arm_link"
    sequence: list[dict[str, ContactState]] = []
    for k in range(15):
        c = [-0.15, 0.0, 0.05 + k * 0.003657522253428563]
        sequence.append({link: ContactState(link, k, True, c, [19.14164927447924, 0.0, 0.0],
                                            [0.0, 0.0, 0.0], c, c, 9)})
    sequence += [{} for _ in range(40)]
    results = run_against_reference(WholeBodyController(FakeKinematics(), config),
                                    RefController(FakeKinematics(), config), Q0, sequence)
    forearm = [r.tasks[1] for r in results]
    lost = [k for k, t in enumerate(forearm) if t.safety is Safety.CONTACT_LOST]
    assert lost and lost[0] == 47, lost[:3]
    assert all(t.phase is Phase.INACTIVE and not np.any(t.target) for t in forearm[47:])


def test_fast_step_equals_reference_on_the_real_robot() -> None:
    # The production kinematics (MuJoCo, Jacobians written in place) on both sides.
    kinematics = pytest.importorskip("wholebody_controller.kinematics")
    config = ControllerConfig()
    fast = WholeBodyController(kinematics.RobotKinematics(), config)
    ref = RefController(kinematics.RobotKinematics(), config)
    rng = np.random.default_rng(3)
    q = np.zeros(15)
    q[3:] = [0.3, -1.2, 1.5, -1.0, -1.57, 0.0, -0.3, -1.9, -1.5, -1.0, 1.57, 0.0]
    for k in range(60):
        contacts = {}
        for i, link in enumerate(SKIN_LINKS):
            if (k // 15 + i) % 2 == 0:
                c = np.array([-0.15, 0.0, 0.05]) + 0.01 * rng.normal(size=3)
                contacts[link] = ContactState(link, k, True, c, rng.normal(scale=8.0, size=3),
                                              rng.normal(scale=0.3, size=3), c - 0.02,
                                              c + 0.02, 20)
        a, b = fast.step(q, contacts), ref.step(q, contacts)
        assert_same_step(a, b)
        q = q + 0.01 * a.qdot


# -- pieces ---------------------------------------------------------------------------------------
@pytest.mark.parametrize("coupled", [False, True])
def test_admittance_step_is_phi_s_plus_gamma_w(coupled: bool) -> None:
    rng = np.random.default_rng(2)
    if coupled:
        m = rng.normal(size=(6, 6))
        lam = m @ m.T + 6.0 * np.eye(6)  # SPD, not diagonal
        d = 30.0 * np.eye(6) + 0.5 * np.ones((6, 6))
    else:
        lam, d = np.diag(rng.uniform(0.1, 1.0, 6)), np.diag(rng.uniform(5.0, 200.0, 6))
    k = np.zeros((6, 6))
    phi, gamma = discretise(lam, d, k, 0.01)
    row, state = np.zeros(12), np.zeros(12)
    for _ in range(50):
        w = rng.normal(scale=5.0, size=6)
        admittance_step(row, transition(lam, d, k, 0.01), tuple(w.tolist()))
        state = phi @ state + gamma @ w
    np.testing.assert_allclose(row, state, rtol=TOL, atol=1e-12)


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**31 - 1))
def test_qp_assembly_equals_the_reference(seed: int) -> None:
    rng = np.random.default_rng(seed)
    n, tasks = 15, int(rng.integers(1, 5))
    jac = rng.normal(size=(6 * tasks, n))
    target = rng.normal(size=6 * tasks)
    psi = rng.choice([1e-4, 0.05, 0.5, 1.0], size=tasks)
    q = rng.uniform(-2.0, 2.0, n)
    pos_lo = np.where(rng.random(n) < 0.3, -np.inf, q - rng.uniform(-0.05, 0.05, n))
    pos_hi = np.where(rng.random(n) < 0.3, np.inf, np.maximum(pos_lo, q + rng.uniform(
        -0.05, 0.05, n)))
    vmax = rng.uniform(0.0, 0.3, n)
    eps, horizon = float(rng.choice([1e-3, 0.1])), float(rng.choice([0.01, 0.15]))
    lower, upper = ref_velocity_bounds(q, pos_lo, pos_hi, -vmax, vmax, horizon)
    expected = ref_build_qp(jac, target, psi.tolist(), eps, lower, upper)
    got = build_qp([jac], [target], psi.tolist(), eps, *velocity_bounds(
        q, pos_lo, pos_hi, -vmax, vmax, horizon))
    for name in ("hessian", "gradient"):
        np.testing.assert_allclose(getattr(got, name), getattr(expected, name), rtol=1e-12,
                                   atol=1e-12)
    np.testing.assert_array_equal(got.lower, expected.lower)
    np.testing.assert_array_equal(got.upper, expected.upper)
    assert np.all(got.lower <= got.upper)
