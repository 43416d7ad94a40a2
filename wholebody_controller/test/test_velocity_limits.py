"""Per-axis velocity limits (for the `tempo` waltz): each axis of the QP (22) keeps its own bound
min(robot's own, ``velocity_limit``, ``velocity_limits[k]``); bad values are refused by name."""

from __future__ import annotations

import math

import numpy as np
import pytest

from phri_common.params import ParameterValueError
from phri_common.records import ContactState
from wholebody_controller.config import (
    ROBOT_VELOCITY_LIMITS,
    SKIN_LINKS,
    AdmittanceGains,
    ControllerConfig,
    LinkTaskConfig,
    dance_ranges,
)
from wholebody_controller.controller import KinematicsModel, WholeBodyController
from wholebody_controller.parameters import GLOBAL_PARAMS
from wholebody_controller.qp import DaqpSolver, build_qp

ARM = [0.3, -1.2, 1.5, -1.0, -1.57, 0.0]
Q0 = np.array([0.2, -0.1, 0.4, *ARM, *[-a for a in ARM]])
CENTER = np.array([-0.15, 0.0, 0.05])
# Distinct bounds per axis: base x, y [m/s], yaw [rad/s], then 12 arm joints [rad/s].
PER_AXIS = (0.04, 0.03, 0.2, 0.05, 0.06, 0.07, 0.08, 0.09, 0.1, 0.11, 0.12, 0.13, 0.14, 0.15,
            0.16)


def test_box_qp_with_per_axis_bounds_is_the_clipped_target() -> None:
    # min Σ (u_k − b_k)² + ε‖u‖² with a diagonal Hessian separates by axis: the optimum is
    # b/(1+ε) clipped into each axis's own box (analytic, independent of the solver).
    rng = np.random.default_rng(0)
    n, eps = 15, 0.1
    target = rng.uniform(-2.0, 2.0, n)
    bound = np.array(PER_AXIS)
    problem = build_qp([np.eye(n)[:6], np.eye(n)[6:12], np.eye(n)[[12, 13, 14, 0, 1, 2]]],
                       [target[:6], target[6:12], target[[12, 13, 14, 0, 1, 2]]],
                       [1.0, 1.0, 1.0], eps, -bound, bound)
    u = DaqpSolver().solve(problem)
    # Axes 0-2 appear in two tasks (weight 2).
    weight = np.ones(n)
    weight[:3] = 2.0
    expected = np.clip(weight * target / (weight + eps), -bound, bound)
    np.testing.assert_allclose(u, expected, atol=1e-9)
    assert np.sum(np.abs(u) >= bound - 1e-12) >= 10  # most axes at their own bound


def _hard_push(kin: KinematicsModel, config: ControllerConfig, steps: int) -> np.ndarray:
    """Largest |command| per axis over ``steps`` periods of a 200 N push on the left forearm."""
    ctl = WholeBodyController(kin, config)
    peak = np.zeros(15)
    q = Q0.copy()
    for k in range(steps):
        kin.update(q)
        rot, _ = kin.link_pose("left_forearm_link")
        force = np.asarray(rot).T @ np.array([0.0, 200.0, 0.0])
        contacts = {"left_forearm_link": ContactState(
            "left_forearm_link", k, True, CENTER, force, np.zeros(3),
            CENTER - 0.02, CENTER + 0.02, 16)}
        res = ctl.step(q, contacts)
        peak = np.maximum(peak, np.abs(res.command))
        q = q + 0.01 * res.qdot
    return peak


def test_each_axis_keeps_its_own_bound_under_a_hard_push(kin: KinematicsModel) -> None:
    gains = AdmittanceGains((0.1,) * 6, (1.0,) * 6, (0.0,) * 6)
    config = ControllerConfig(links=tuple(LinkTaskConfig(n, gains) for n in SKIN_LINKS),
                              velocity_limit=10.0, velocity_limits=PER_AXIS)
    peak = _hard_push(kin, config, 40)
    bound = np.minimum(np.array(PER_AXIS), kin.velocity_limits)
    assert np.all(peak <= bound + 1e-12)
    # The push saturates the base's x and y, each at its own (different) bound.
    np.testing.assert_allclose(peak[:2], PER_AXIS[:2], atol=1e-9)


def test_joint_out_of_range_returns_at_its_own_bound(kin: KinematicsModel) -> None:
    q = Q0.copy()
    q[5] += 0.5  # left elbow 0.5 rad beyond q_dance
    q[12] -= 0.5  # right elbow 0.5 rad below
    config = ControllerConfig(joint_ranges=dance_ranges(kin.joint_names[3:], list(Q0[3:]), 0.1),
                              velocity_limit=1.0, velocity_limits=PER_AXIS)
    ctl = WholeBodyController(kin, config)
    first = ctl.step(q, {})
    # From rest at the rated 2 rad/s²: 0.02 rad/s in the first 10 ms period ...
    assert first.command[5] == pytest.approx(-0.02) and first.command[12] == pytest.approx(0.02)
    for _ in range(10):  # ... then at its own bound once ramped up (0.07 and 0.14 rad/s)
        res = ctl.step(q, {})
    assert res.command[5] == pytest.approx(-PER_AXIS[5])
    assert res.command[12] == pytest.approx(PER_AXIS[12])


def test_scalar_limit_and_robot_limits_still_bound_every_axis(kin: KinematicsModel) -> None:
    config = ControllerConfig(velocity_limit=0.1, velocity_limits=(5.0,) * 15)
    ctl = WholeBodyController(kin, config)
    np.testing.assert_allclose(ctl.velocity_upper, np.minimum(kin.velocity_limits, 0.1))
    config = ControllerConfig(velocity_limit=10.0, velocity_limits=(10.0,) * 15)
    np.testing.assert_allclose(WholeBodyController(kin, config).velocity_upper,
                               kin.velocity_limits)


@pytest.mark.parametrize("bad", [-0.1, math.nan, math.inf])
def test_bad_per_axis_value_is_refused_by_name(bad: float) -> None:
    values = list(PER_AXIS)
    values[4] = bad
    with pytest.raises(ValueError, match=r"velocity_limits\[4\]"):
        ControllerConfig(velocity_limits=tuple(values))


def test_wrong_length_is_refused_by_name(kin: KinematicsModel) -> None:
    with pytest.raises(ValueError, match=r"'velocity_limits'.*15 elements"):
        WholeBodyController(kin, ControllerConfig(velocity_limits=PER_AXIS[:14]))
    spec = next(s for s in GLOBAL_PARAMS if s.name == "velocity_limits")
    with pytest.raises(ParameterValueError, match=r"'velocity_limits'.*15 elements"):
        spec.check(list(PER_AXIS[:14]))
    with pytest.raises(ParameterValueError,
                       match=r"'velocity_limits\[0\]'.* refused value 11\.0: above"):
        spec.check([11.0] * 15)


def test_default_is_the_robot_description_limits(robot_kinematics: KinematicsModel) -> None:
    # Rounded up, never below the description's, so the default changes no bound.
    own = robot_kinematics.velocity_limits
    assert len(ROBOT_VELOCITY_LIMITS) == 15
    assert np.all(np.array(ROBOT_VELOCITY_LIMITS) >= own)
    assert np.all(np.array(ROBOT_VELOCITY_LIMITS) - own < 1e-3)
    ctl = WholeBodyController(robot_kinematics, ControllerConfig(
        velocity_limit=10.0, velocity_limits=tuple(ROBOT_VELOCITY_LIMITS)))
    np.testing.assert_array_equal(ctl.velocity_upper, own)
