"""Decision logic of the arm bridge (ArmSupervisor) against the rules in docs/hardware.md."""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from phri_hardware.ur_arm import (
    Action,
    ArmState,
    ArmSupervisor,
    BridgeConfig,
    CommandError,
    RobotMode,
    SafetyMode,
    robot_fault,
    validate_command,
)

OK = ArmState(q=(0.0,) * 6, qd=(0.0,) * 6, robot_mode=RobotMode.RUNNING,
              safety_mode=SafetyMode.NORMAL)
PSTOP = ArmState(q=(0.0,) * 6, qd=(0.0,) * 6, robot_mode=RobotMode.RUNNING,
                 safety_mode=SafetyMode.PROTECTIVE_STOP, protective_stopped=True)
QD = (0.1, -0.1, 0.05, 0.0, 0.0, 0.02)


def armed_supervisor(config: BridgeConfig | None = None) -> ArmSupervisor:
    sup = ArmSupervisor(config or BridgeConfig())
    sup.command([0.0] * 6, 0.0)
    assert sup.step(0.0, OK).action is Action.SPEED_J
    return sup


def test_design_velocity_limits_are_enforced_per_joint() -> None:
    # design §5: 120°/s shoulder pan and lift, 180°/s the others; with no extra cap a shoulder
    # command of 2.2 rad/s (126°/s) is refused while the same speed on the elbow passes.
    limits = BridgeConfig(velocity_cap=3.15).effective_limits
    with pytest.raises(CommandError, match="shoulder_lift_joint"):
        validate_command([0.0, 2.2, 0.0, 0.0, 0.0, 0.0], limits)
    assert validate_command([0.0, 0.0, 2.2, 0.0, 0.0, 0.0], limits)[2] == 2.2
    # the configurable cap lowers every joint's limit
    with pytest.raises(CommandError, match="wrist_3_joint"):
        validate_command([0.0] * 5 + [0.31], BridgeConfig(velocity_cap=0.3).effective_limits)


@pytest.mark.parametrize("bad", [[math.nan] + [0.0] * 5, [0.0] * 5 + [math.inf],
                                 [0.0] * 5, [0.0] * 7, [0.0, 0.0, -0.5, 0.0, 0.0, 0.0]])
def test_refused_commands_become_zero_velocity(bad: list[float]) -> None:
    sup = armed_supervisor(BridgeConfig(velocity_cap=0.3))
    sup.command(list(QD), 1.0)
    assert sup.step(1.0, OK).qd == QD
    assert sup.command(bad, 1.01) is not None
    decision = sup.step(1.01, OK)
    assert decision.action is Action.SPEED_J
    assert decision.qd == (0.0,) * 6
    assert sup.counters.refused == 1


def test_starts_moving_only_on_a_near_zero_command_in_running_normal() -> None:
    sup = ArmSupervisor(BridgeConfig(rearm_velocity=0.01))
    sup.command(list(QD), 0.0)
    assert sup.step(0.0, OK).action is Action.NONE  # disarmed: 0.1 rad/s is no arming command
    for mode in (RobotMode.POWER_ON, RobotMode.IDLE, RobotMode.BACKDRIVE):
        sup.command([0.0] * 6, 0.01)
        state = ArmState(q=OK.q, qd=OK.qd, robot_mode=mode, safety_mode=SafetyMode.NORMAL)
        assert sup.step(0.01, state).action is Action.NONE
        assert "robot mode" in sup.hold_reason
    reduced = ArmState(q=OK.q, qd=OK.qd, robot_mode=RobotMode.RUNNING,
                       safety_mode=SafetyMode.REDUCED)
    assert sup.step(0.01, reduced).action is Action.NONE
    assert ArmSupervisor(BridgeConfig(allow_reduced_safety=True)).config.allow_reduced_safety
    assert robot_fault(reduced, allow_reduced_safety=True) is None
    sup.command([0.005] * 6, 0.02)
    assert sup.step(0.02, OK).action is Action.SPEED_J
    sup.command(list(QD), 0.03)
    assert sup.step(0.03, OK).qd == QD


def test_stale_command_stops_once_then_stays_quiet() -> None:
    sup = armed_supervisor(BridgeConfig(command_timeout=0.1))
    sup.command(list(QD), 1.0)
    assert sup.step(1.05, OK).action is Action.SPEED_J
    assert sup.step(1.11, OK).action is Action.SPEED_STOP
    assert [sup.step(t, OK).action for t in (1.2, 1.3, 1.4)] == [Action.NONE] * 3
    assert sup.counters.stale_stops == 1
    sup.command(list(QD), 1.5)  # the stream comes back: no re-arm needed after staleness
    assert sup.step(1.5, OK).action is Action.SPEED_J


def test_protective_stop_stops_and_needs_rearming() -> None:
    sup = armed_supervisor()
    sup.command(list(QD), 1.0)
    assert sup.step(1.0, OK).action is Action.SPEED_J
    sup.command(list(QD), 1.01)
    assert sup.step(1.01, PSTOP).action is Action.SPEED_STOP
    for k in range(10):
        sup.command(list(QD), 1.02 + 0.01 * k)
        assert sup.step(1.02 + 0.01 * k, PSTOP).action is Action.NONE
        assert sup.hold_reason == "protective stop"
    sup.command(list(QD), 1.2)
    assert sup.step(1.2, OK).action is Action.NONE  # released, but the old speed is not resumed
    sup.command([0.0] * 6, 1.21)
    assert sup.step(1.21, OK).action is Action.SPEED_J
    assert sup.counters.fault_stops == 1


def test_shutdown_stops() -> None:
    sup = armed_supervisor()
    assert sup.shutdown().action is Action.SPEED_STOP
    sup.command(list(QD), 0.0)
    assert sup.step(0.0, OK).action is Action.NONE  # disarmed again


states = st.sampled_from([OK, PSTOP,
                          ArmState(q=OK.q, qd=OK.qd, robot_mode=RobotMode.IDLE,
                                   safety_mode=SafetyMode.NORMAL),
                          ArmState(q=OK.q, qd=OK.qd, robot_mode=RobotMode.RUNNING,
                                   safety_mode=SafetyMode.NORMAL, emergency_stopped=True),
                          ArmState(q=OK.q, qd=OK.qd, robot_mode=RobotMode.RUNNING,
                                   safety_mode=SafetyMode.NORMAL, program_running=False)])
speeds = st.floats(allow_nan=True, allow_infinity=True, min_value=None, max_value=None)
events = st.lists(
    st.tuples(st.floats(0.0, 0.3), st.one_of(st.none(), st.lists(speeds, min_size=6,
                                                                  max_size=6)), states),
    min_size=1, max_size=60,
)


@settings(max_examples=200, deadline=None)
@given(events)
def test_never_moves_on_fault_stale_or_out_of_limit(seq: list) -> None:
    config = BridgeConfig(command_timeout=0.1, velocity_cap=0.3)
    limits = config.effective_limits
    sup = ArmSupervisor(config)
    now = 0.0
    last_cmd: float | None = None
    moving = False
    for dt, cmd, state in seq:
        now += dt
        if cmd is not None:
            sup.command(cmd, now)
            last_cmd = now
        decision = sup.step(now, state)
        if decision.action is Action.SPEED_J:
            assert robot_fault(state) is None
            assert last_cmd is not None and now - last_cmd <= config.command_timeout
            assert all(math.isfinite(v) and abs(v) <= lim
                       for v, lim in zip(decision.qd, limits, strict=True))
            moving = True
        elif decision.action is Action.SPEED_STOP:
            assert moving  # a stop only ends motion the bridge started
            moving = False
        if robot_fault(state) is not None:
            assert not moving
