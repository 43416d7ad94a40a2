"""The ur_rtde wrapper calls methods that exist in the installed ur_rtde and maps its values."""

from __future__ import annotations

import math
import sys
import types
from typing import Any

import pytest
import rtde_control
import rtde_receive

from phri_hardware.rtde_arm import RECEIVE_VARIABLES, UrRtdeArm, UrRtdeArmFactory
from phri_hardware.ur_arm import RobotMode, SafetyMode

RECEIVE_CALLS = ("isConnected", "getActualQ", "getActualQd", "getRobotMode", "getSafetyMode",
                 "isProtectiveStopped", "isEmergencyStopped", "getSpeedScalingCombined",
                 "getActualCurrent", "getTargetCurrent", "getTargetMoment", "disconnect")
CONTROL_CALLS = ("isConnected", "isProgramRunning", "speedJ", "speedStop", "setWatchdog",
                 "kickWatchdog", "reuploadScript", "stopScript", "disconnect")


def test_every_called_method_exists_in_ur_rtde() -> None:
    for name in RECEIVE_CALLS:
        assert hasattr(rtde_receive.RTDEReceiveInterface, name), name
    for name in CONTROL_CALLS:
        assert hasattr(rtde_control.RTDEControlInterface, name), name
    # speedJ(qd, acceleration, time) as the bridge calls it
    assert "acceleration" in rtde_control.RTDEControlInterface.speedJ.__doc__


class Recorder:
    """Stands in for both ur_rtde interfaces; answers like a robot in RUNNING / NORMAL."""

    def __init__(self, host: str, frequency: float = -1.0,
                 variables: list[str] | None = None) -> None:
        self.host, self.frequency, self.variables = host, frequency, variables
        self.calls: list[tuple[str, tuple[Any, ...]]] = []
        self.fail = False

    def _answer(self, name: str, *args: Any) -> Any:
        self.calls.append((name, args))
        if self.fail:
            raise RuntimeError("RTDE connection lost")
        return {"getActualQ": [0.1] * 6, "getActualQd": [0.0] * 6,
                "getRobotMode": 7, "getSafetyMode": 1, "isProtectiveStopped": False,
                "isEmergencyStopped": False, "getSpeedScalingCombined": 0.3,
                "getActualCurrent": [2.0, 4.0, 1.0, 0.5, 0.0, 0.0],
                "getTargetCurrent": [2.0, 3.0, 1.0, 0.05, 0.0, 0.0],
                "getTargetMoment": [20.0, 30.0, 12.0, 0.3, 0.0, 0.0]}.get(name, True)

    def __getattr__(self, name: str) -> Any:
        return lambda *args: self._answer(name, *args)


@pytest.fixture
def fake_ur_rtde(monkeypatch: pytest.MonkeyPatch) -> dict[str, Recorder]:
    made: dict[str, Recorder] = {}

    def module(name: str, cls: str) -> types.ModuleType:
        mod = types.ModuleType(name)

        def build(host: str, frequency: float = -1.0,
                  variables: list[str] | None = None) -> Recorder:
            made[name] = Recorder(host, frequency, variables)
            return made[name]

        setattr(mod, cls, build)
        return mod

    monkeypatch.setitem(sys.modules, "rtde_receive",
                        module("rtde_receive", "RTDEReceiveInterface"))
    monkeypatch.setitem(sys.modules, "rtde_control",
                        module("rtde_control", "RTDEControlInterface"))
    return made


def test_wrapper_maps_state_and_commands(fake_ur_rtde: dict[str, Recorder]) -> None:
    arm = UrRtdeArmFactory("10.0.0.7", 500.0)()
    assert isinstance(arm, UrRtdeArm)
    assert not arm.read_state().connected  # before connect
    arm.connect()
    assert fake_ur_rtde["rtde_control"].host == "10.0.0.7"
    state = arm.read_state()
    assert state.connected and state.q == (0.1,) * 6
    assert state.robot_mode == RobotMode.RUNNING and state.safety_mode == SafetyMode.NORMAL
    assert state.speed_scaling == 0.3
    # τ = i_actual · (τ_target / i_target) where |i_target| ≥ 0.1 A, nan before a first such one
    assert state.effort[:3] == (20.0, 40.0, 12.0)
    assert all(math.isnan(x) for x in state.effort[3:])
    assert arm.speed_j([0.1] * 6, 2.0, 0.01)
    assert ("speedJ", ([0.1] * 6, 2.0, 0.01)) in fake_ur_rtde["rtde_control"].calls
    assert arm.speed_stop(4.0) and arm.set_watchdog(10.0) and arm.kick_watchdog()
    fake_ur_rtde["rtde_receive"].fail = True
    assert not arm.read_state().connected  # a ur_rtde error reads as a lost connection
    arm.disconnect()
    names = [n for n, _ in fake_ur_rtde["rtde_control"].calls]
    assert names[-2:] == ["stopScript", "disconnect"]


def test_receive_only_opens_no_control_interface(fake_ur_rtde: dict[str, Recorder]) -> None:
    arm = UrRtdeArmFactory("10.0.0.7", 500.0, receive_only=True)()
    arm.connect()
    assert "rtde_control" not in fake_ur_rtde  # no dashboard, no script, no command channel
    assert fake_ur_rtde["rtde_receive"].variables == RECEIVE_VARIABLES
    state = arm.read_state()
    assert state.connected and state.q == (0.1,) * 6 and not state.program_running
    # Commands are impossible, not merely unsent.
    assert not arm.speed_j([0.1] * 6, 2.0, 0.01)
    assert not arm.speed_stop(4.0) and not arm.kick_watchdog()
    arm.disconnect()
