"""The guard against contacts no skin feels (``wholebody_controller.torque_guard``): it passes the
dance, slows the motion into a growing unsensed contact, stops the robot and backs off along the
torque at its limit, and resumes only once the torque has stayed low.

Efforts are fed as an arm would report them: the gravity torques the drives carry minus the
external torque of a push (the estimator's model, ``test_external_torque.py``, is checked there)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from phri_description.description import JOINT_NAMES, robot_description
from wholebody_controller.config import ControllerConfig
from wholebody_controller.external_torque import ArmDynamics
from wholebody_controller.torque_guard import (
    UNSENSED_TORQUE_STOP,
    GuardState,
    TorqueGuardConfig,
    TorqueWatch,
    axis_ratios,
    backoff_command,
    slow_command,
)

Q = np.array([0.0, 0.0, 0.5, 0.0, -0.3, 0.3, math.pi, 0.0, 0.0,
              0.0, 0.3, -0.3, 0.0, 0.0, 0.0])
LIMITS = np.array(UNSENSED_TORQUE_STOP)
POSITION_LIMITS = robot_description().position_limits()
STEP = np.full(15, 1.0)  # a generous rated-acceleration step: the tests see the target itself
COMMAND = np.array([0.1, -0.05, 0.1, 0.1, -0.1, 0.1, 0.0, 0.0, 0.0, 0.1, 0.1, -0.1, 0.0, 0.0,
                    0.0])


@pytest.fixture(scope="module")
def dynamics() -> ArmDynamics:
    return ArmDynamics()


class FakeController:
    """What TorqueWatch.apply uses of the controller."""

    def __init__(self) -> None:
        self.previous_command = np.zeros(15)
        self.limits = np.vstack([np.zeros((4, 15)), STEP])
        self.config = ControllerConfig()
        self.resets = 0

    def reset(self) -> None:
        self.resets += 1
        self.previous_command[...] = 0.0


class Arm:
    """Feeds a TorqueWatch the readings of a still robot at Q with an external torque."""

    def __init__(self, watch: TorqueWatch) -> None:
        self.watch, self.t = watch, 0.0
        self.gravity = watch.estimator.dynamics.needed(Q, np.zeros(15), np.zeros(15))

    def cycle(self, external: np.ndarray, command: np.ndarray = COMMAND,
              controller: FakeController | None = None) -> np.ndarray:
        self.t += 0.01
        est = self.watch.estimator
        est.base(self.t, Q[:3])
        est.joints(self.t, JOINT_NAMES, Q, np.zeros(15), self.gravity - external)
        return self.watch.apply(controller or FakeController(), self.t, command, Q, {})


def wrist_push(newtons_at_limit: float) -> np.ndarray:
    """External torques of a push on the left wrist scaled so the worst ratio is
    ``newtons_at_limit`` (a fraction of the limit)."""
    tau = np.zeros(15)
    tau[3:9] = [10.0, -30.0, 12.0, 4.0, -2.0, 0.5]
    return tau * newtons_at_limit / float(np.max(axis_ratios(tau, LIMITS)))


def watch(dynamics: ArmDynamics, **settings: object) -> TorqueWatch:
    config = TorqueGuardConfig(filter_time=0.0, **settings)  # type: ignore[arg-type]
    return TorqueWatch(config, POSITION_LIMITS, dynamics)


def test_no_contact_passes_the_command_unchanged(dynamics: ArmDynamics) -> None:
    arm = Arm(watch(dynamics))
    for _ in range(5):
        assert np.array_equal(arm.cycle(np.zeros(15)), COMMAND)
    assert arm.watch.report.state is GuardState.OK and arm.watch.report.ratio < 1e-6
    assert arm.watch.report.sensed


def test_a_growing_unsensed_push_slows_then_stops_and_backs_off(dynamics: ArmDynamics) -> None:
    arm = Arm(watch(dynamics))
    assert np.array_equal(arm.cycle(wrist_push(0.4)), COMMAND)
    slowed = arm.cycle(wrist_push(0.75))
    assert arm.watch.report.state is GuardState.SLOWING
    scale = (1 - 0.75) / (1 - 0.5)
    assert slowed[:3] == pytest.approx(COMMAND[:3] * scale)  # no force on the base: all of it
    tau = wrist_push(0.75)
    against = COMMAND[3:] * tau[3:] < 0
    assert slowed[3:][against] == pytest.approx(COMMAND[3:][against] * scale)
    assert slowed[3:][~against] == pytest.approx(COMMAND[3:][~against])  # giving way: kept
    ctl = FakeController()
    stopped = arm.cycle(wrist_push(1.2), controller=ctl)
    assert arm.watch.report.state is GuardState.STOPPED and ctl.resets == 1
    assert np.all(stopped[:3] == 0.0)  # the base stops
    tau = wrist_push(1.2)
    moving = np.abs(stopped[3:]) > 0
    assert moving.any() and np.all(stopped[3:][moving] * tau[3:][moving] > 0)  # along τ
    assert np.max(np.abs(stopped)) <= 0.1 + 1e-12
    assert np.array_equal(ctl.previous_command, stopped)  # the next QP starts from it
    arm.cycle(wrist_push(1.5), controller=ctl)
    assert ctl.resets == 1  # reset once, on entering


def test_a_stopped_robot_resumes_only_after_the_torque_stayed_low(dynamics: ArmDynamics) -> None:
    arm = Arm(watch(dynamics, resume_time=0.05))
    ctl = FakeController()
    arm.cycle(wrist_push(1.1), controller=ctl)
    assert arm.watch.report.state is GuardState.STOPPED
    arm.cycle(wrist_push(0.45))  # below the slow ratio, above the resume ratio: stays
    assert arm.watch.report.state is GuardState.STOPPED
    for _ in range(4):  # low for 0.04 s < resume_time
        assert np.all(arm.cycle(wrist_push(0.1))[:3] == 0.0)
        assert arm.watch.report.state is GuardState.STOPPED
    arm.cycle(wrist_push(0.1))
    arm.cycle(wrist_push(0.1), controller=ctl)
    assert arm.watch.report.state is GuardState.OK
    assert ctl.resets == 2  # on stopping and on resuming
    assert np.array_equal(arm.cycle(wrist_push(0.1)), COMMAND)
    assert arm.watch.report.stops == 1


def test_the_base_stops_on_a_push_only_its_drives_feel(dynamics: ArmDynamics) -> None:
    """A contact on the base itself (its column, or a link near the shoulder axes) loads no arm
    joint: its drives' forces show it, and the robot stops and gives way along the push."""
    arm = Arm(watch(dynamics))
    push = np.zeros(15)
    push[0:2] = [-70.0, 0.0]  # world x: 70 N against the base's 60 N limit
    out = arm.cycle(push)
    assert arm.watch.report.state is GuardState.STOPPED and arm.watch.report.joint == "base_x"
    # Along the push in the world, i.e. turned by −yaw into the base frame.
    c, s = math.cos(Q[2]), math.sin(Q[2])
    direction = np.array([c * -1.0 + s * 0.0, -s * -1.0 + c * 0.0])
    assert out[:2] == pytest.approx(0.1 * direction)


def test_disabled_guard_reports_but_does_not_act(dynamics: ArmDynamics) -> None:
    arm = Arm(watch(dynamics, enabled=False))
    assert np.array_equal(arm.cycle(wrist_push(2.0)), COMMAND)
    assert arm.watch.report.ratio == pytest.approx(2.0)
    assert arm.watch.report.state is GuardState.OK and arm.watch.report.stops == 0


def test_joints_without_efforts_are_reported_unguarded(dynamics: ArmDynamics) -> None:
    w = watch(dynamics)
    w.estimator.joints(0.01, JOINT_NAMES[3:], Q[3:], [0.0] * 12, [])
    w.apply(FakeController(), 0.01, COMMAND, Q, {})
    assert not w.report.sensed and set(w.report.unsensed) == set(JOINT_NAMES)


def test_backoff_keeps_within_limits_and_rated_acceleration() -> None:
    tau = np.zeros(15)
    tau[4] = 80.0  # left shoulder lift pushed positive, 2× its limit
    near = Q.copy()
    near[4] = POSITION_LIMITS[4, 1] - 0.005  # 5 mm from its upper limit: no further
    out = backoff_command(tau, LIMITS, 0.1, near, POSITION_LIMITS, np.zeros(15), STEP, 0.15)
    assert out[4] == 0.0
    out = backoff_command(tau, LIMITS, 0.1, Q, POSITION_LIMITS, np.zeros(15), STEP, 0.15)
    assert out[4] == pytest.approx(0.1)
    small = np.full(15, 0.02)
    out = backoff_command(tau, LIMITS, 0.1, Q, POSITION_LIMITS, np.zeros(15), small, 0.15)
    assert out[4] == pytest.approx(0.02)


def test_slow_command_scales_only_the_motion_into_the_contact() -> None:
    tau = np.zeros(15)
    tau[3:5] = [5.0, -5.0]
    command = np.zeros(15)
    command[:3] = [0.2, 0.0, 0.1]
    command[3:5] = [0.1, 0.1]  # joint 3 gives way (along τ), joint 4 pushes (against)
    out = slow_command(command, tau, 0.5, 0.0)
    assert out[:3] == pytest.approx([0.1, 0.0, 0.05])  # the base reports no force: all of it
    assert out[3] == pytest.approx(0.1) and out[4] == pytest.approx(0.05)
    tau[:3] = [0.0, 20.0, -3.0]  # a push on the base along world +y, a torque about −z
    yaw = 0.5 * math.pi  # world +y is the base's +x
    command[:3] = [-0.2, 0.1, 0.1]  # into the push along base x, across it along base y
    out = slow_command(command, tau, 0.5, yaw)
    assert out[:3] == pytest.approx([-0.1, 0.1, 0.05])
    command[:3] = [0.2, 0.1, -0.1]  # giving way to both
    assert slow_command(command, tau, 0.5, yaw)[:3] == pytest.approx([0.2, 0.1, -0.1])


def test_resume_ratio_above_slow_ratio_is_refused() -> None:
    with pytest.raises(ValueError, match="unsensed_resume_ratio"):
        TorqueGuardConfig(slow_ratio=0.3, resume_ratio=0.4)
    with pytest.raises(ValueError, match="unsensed_torque_stop"):
        TorqueGuardConfig(stop_torques=(0.0,) * 15)
