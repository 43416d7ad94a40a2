"""External joint torques from the arms' own readings (``wholebody_controller.external_torque``):
gravity and motion are not contacts, a push on an unsensed link is, and the skin's share of it is
what the skin reports.

The references are independent of the module's formula: gravity from the bodies' masses and
centres (the torque of m g about each joint axis), the push's joint torques from finite
differences of the pushed point's position."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from phri_common.records import ContactState
from phri_description.description import JOINT_NAMES
from wholebody_controller.external_torque import (
    ArmDynamics,
    ExternalTorqueEstimator,
    unexplained,
)

Q = np.array([0.3, -0.2, 0.4, 0.0, -0.3, 0.3, math.pi, 0.0, 0.0,
              0.0, 0.3, -0.3, 0.0, 0.0, 0.0])
"""A waltz-like configuration (base moved and turned) [m, rad]."""


@pytest.fixture(scope="module")
def dynamics() -> ArmDynamics:
    return ArmDynamics()


def gravity_torques(dyn: ArmDynamics, q: np.ndarray) -> np.ndarray:
    """τ_g,j = Σ_b (a_j × (c_b − o_j)) · (−m_b g ẑ) over the bodies b beyond joint j: the
    torque the drives need to hold the arm still (independent of mj_rne)."""
    m, d = dyn.model, mujoco.MjData(dyn.model)
    d.qpos[:] = q
    mujoco.mj_kinematics(m, d)
    out = np.zeros(15)
    for i, name in enumerate(JOINT_NAMES):
        joint = m.joint(name).id
        if m.jnt_type[joint] != mujoco.mjtJoint.mjJNT_HINGE or i < 3:
            continue
        axis, anchor = d.xaxis[joint], d.xanchor[joint]
        for body in range(1, m.nbody):
            b, beyond = body, False
            while b > 0:
                beyond |= b == m.jnt_bodyid[joint]
                b = m.body_parentid[b]
            if beyond:
                weight = np.array([0.0, 0.0, -9.81 * m.body_mass[body]])
                out[i] -= np.dot(axis, np.cross(d.xipos[body] - anchor, weight))
    return out


def point_jacobian_fd(dyn: ArmDynamics, q: np.ndarray, body: str, local: np.ndarray,
                      h: float = 1e-6) -> np.ndarray:
    """3×15 Jacobian of a point fixed on ``body`` by central differences."""
    m, d = dyn.model, mujoco.MjData(dyn.model)
    b = m.body(body).id

    def where(qq: np.ndarray) -> np.ndarray:
        d.qpos[:] = qq
        mujoco.mj_kinematics(m, d)
        return d.xmat[b].reshape(3, 3) @ local + d.xpos[b]

    jac = np.zeros((3, 15))
    for k in range(15):
        dq = np.zeros(15)
        dq[k] = h
        jac[:, k] = (where(q + dq) - where(q - dq)) / (2 * h)
    return jac


def estimator_at_rest(dyn: ArmDynamics, q: np.ndarray, effort: np.ndarray
                      ) -> ExternalTorqueEstimator:
    est = ExternalTorqueEstimator(dyn, filter_time=0.0)
    est.base(0.0, q[:3])
    est.joints(0.0, JOINT_NAMES, q, np.zeros(15), effort)
    return est


def test_gravity_is_not_a_contact(dynamics: ArmDynamics) -> None:
    gravity = gravity_torques(dynamics, Q)
    assert np.max(np.abs(gravity[3:])) > 20.0  # the shoulders carry tens of N·m
    est = estimator_at_rest(dynamics, Q, gravity)
    assert np.max(np.abs(est.tau)) < 1e-6


def test_a_push_on_an_unsensed_wrist_is_external_and_unexplained(dynamics: ArmDynamics) -> None:
    local = np.array([0.0, 0.05, 0.02])
    push = np.array([30.0, -20.0, 10.0])  # world [N] on the left wrist 2
    jac = point_jacobian_fd(dynamics, Q, "left_wrist_2_link", local)
    external = jac.T @ push
    est = estimator_at_rest(dynamics, Q, gravity_torques(dynamics, Q) - external)
    assert est.tau == pytest.approx(external, abs=1e-4)
    no_skin = est.skin(Q, {})
    assert np.all(no_skin == 0.0)
    assert unexplained(est.tau, no_skin) == pytest.approx(external, abs=1e-4)


def test_a_push_the_skin_reports_is_explained(dynamics: ArmDynamics) -> None:
    local = np.array([0.2, 0.0, 0.06])
    push = np.array([0.0, -12.0, 4.0])
    jac = point_jacobian_fd(dynamics, Q, "left_forearm_link", local)
    est = estimator_at_rest(dynamics, Q, gravity_torques(dynamics, Q) - jac.T @ push)
    d = mujoco.MjData(dynamics.model)
    d.qpos[:] = Q
    mujoco.mj_kinematics(dynamics.model, d)
    rot = d.xmat[dynamics.model.body("left_forearm_link").id].reshape(3, 3)
    state = ContactState("left_forearm_link", 0, True, local, rot.T @ push, np.zeros(3),
                         local - 0.01, local + 0.01, 8)
    skin = est.skin(Q, {"left_forearm_link": state})
    assert np.max(np.abs(unexplained(est.tau, skin))) < 1e-4
    # The same push reported on the wrong link is not explained.
    wrong = ContactState("right_forearm_link", 0, True, local, rot.T @ push, np.zeros(3),
                         local - 0.01, local + 0.01, 8)
    assert np.max(np.abs(unexplained(est.tau, est.skin(Q, {"right_forearm_link": wrong})))) > 1.0


def test_motion_is_not_a_contact(dynamics: ArmDynamics) -> None:
    """A smooth motion of base and arms with the efforts its dynamics need (MuJoCo's own
    ``mj_inverse`` at the mean acceleration of each interval, the efforts a drive averages):
    the estimate, differencing the sampled velocities, stays near zero."""
    m = dynamics.model
    d = mujoco.MjData(m)
    est = ExternalTorqueEstimator(dynamics, filter_time=0.0)
    dt, worst = 0.01, 0.0
    freq = np.linspace(0.5, 1.5, 15)

    def state(t: float) -> tuple[np.ndarray, np.ndarray]:
        return Q + 0.2 * np.sin(freq * t), 0.2 * freq * np.cos(freq * t)

    for k in range(60):
        t = k * dt
        q, qd = state(t)
        _, qd0 = state(t - dt)
        d.qpos[:], d.qvel[:], d.qacc[:] = q, qd, (qd - qd0) / dt
        mujoco.mj_inverse(m, d)
        est.joints(t, JOINT_NAMES, q, qd, d.qfrc_inverse.copy())
        if k >= 2:
            worst = max(worst, float(np.max(np.abs(est.tau))))
    assert worst < 0.05


def test_a_joint_without_effort_is_not_guessed(dynamics: ArmDynamics) -> None:
    est = ExternalTorqueEstimator(dynamics, filter_time=0.0)
    est.joints(0.0, JOINT_NAMES[3:9], Q[3:9], [0.0] * 6, [])  # positions and velocities only
    assert not est.sensed.any() and np.all(est.tau == 0.0)
    gravity = gravity_torques(dynamics, Q)
    est.joints(0.01, JOINT_NAMES[3:9], Q[3:9], [0.0] * 6, gravity[3:9] - 5.0)
    assert est.sensed[3:9].all() and not est.sensed[9:].any()
    assert np.all(est.tau[9:] == 0.0)


def test_the_filter_smooths_a_step(dynamics: ArmDynamics) -> None:
    gravity = gravity_torques(dynamics, Q)
    est = ExternalTorqueEstimator(dynamics, filter_time=0.02)
    est.joints(0.0, JOINT_NAMES, Q, np.zeros(15), gravity)
    est.joints(0.01, JOINT_NAMES, Q, np.zeros(15), gravity - 10.0)
    assert est.tau[3:] == pytest.approx(10.0 * (1.0 - math.exp(-0.5)), rel=1e-6)
