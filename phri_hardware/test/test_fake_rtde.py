"""ur_rtde's RTDEReceiveInterface against the project's fake RTDE server on 127.0.0.1.

The bridge's worker process (the real ur_rtde, not a stand-in) connects to
:class:`phri_hardware.fake_rtde.FakeRtdeServer`: monitor mode reads joint states and modes
through RTDE receive only; control mode fails at the dashboard (the fake serves no dashboard,
as a robot in Local mode or with the dashboard blocked would) and the diagnostics keep that
root cause.
"""

from __future__ import annotations

import math
import time

import pytest

from phri_hardware.arm_worker import ArmLink, WorkerReport
from phri_hardware.fake_arm import FakeArmSpec
from phri_hardware.fake_rtde import I_SETUP_INPUTS, FakeRtdeServer
from phri_hardware.rtde_arm import UrRtdeArmFactory
from phri_hardware.ur_arm import BridgeConfig, SafetyMode

WAIT_S = 60.0
"""Longest wait for something that must happen (a stalled machine); never a measured time."""


def _link(factory: object, monitor: bool) -> ArmLink:
    return ArmLink(factory, BridgeConfig(rate_hz=50.0), connect_timeout=10.0,  # type: ignore[arg-type]
                   report_timeout=10.0, restart_delay=5.0, watchdog_frequency=0.0,
                   monitor=monitor)


def _poll_until(link: ArmLink, done: object, timeout: float) -> list[WorkerReport]:
    reports: list[WorkerReport] = []
    end = time.monotonic() + timeout
    while time.monotonic() < end and not done(link, reports):  # type: ignore[operator]
        reports += link.poll()
        time.sleep(0.01)
    return reports


def test_monitor_mode_reads_the_robot_through_rtde_receive_only(
    rtde_server: FakeRtdeServer,
) -> None:
    link = _link(UrRtdeArmFactory("127.0.0.1", 100.0, receive_only=True), monitor=True)
    link.start()
    try:
        reports = _poll_until(link, lambda lk, r: len(r) >= 20, timeout=WAIT_S)
        assert len(reports) >= 20, f"no reports: {link.status}"
        state = reports[-1].state
        assert state.connected and state.q == pytest.approx(rtde_server.state.q)
        assert state.safety_mode == SafetyMode.NORMAL and not state.protective_stopped
        assert all(r.action == "none" and not r.moving for r in reports)
        with rtde_server.state.lock:  # a protective stop on the robot shows up in the state
            rtde_server.state.protective_stopped = True
            rtde_server.state.safety_mode = SafetyMode.PROTECTIVE_STOP
        later = _poll_until(link, lambda lk, r: any(x.state.protective_stopped for x in r),
                            WAIT_S)
        assert later and later[-1].state.protective_stopped
    finally:
        link.close()
    assert rtde_server.data_sent > 0
    assert I_SETUP_INPUTS not in rtde_server.received  # never asked for an input (command)


def test_speed_scaling_is_read_as_ur_robot_driver_reads_it(rtde_server: FakeRtdeServer) -> None:
    """ur_rtde's combined speed scaling: the pendant's slider (target_speed_fraction) times the
    trajectory limiter's speed_scaling; 0 while a paused program resumes, then ramped back up
    (ur_rtde's getSpeedScalingCombined, as ur_robot_driver computes it)."""
    with rtde_server.state.lock:
        rtde_server.state.speed_scaling = 0.5
        rtde_server.state.target_speed_fraction = 0.6
    link = _link(UrRtdeArmFactory("127.0.0.1", 100.0, receive_only=True), monitor=True)
    link.start()
    try:
        reports = _poll_until(link, lambda lk, r: len(r) >= 10, timeout=15.0)
        assert reports, f"no reports: {link.status}"
        assert reports[-1].state.speed_scaling == pytest.approx(0.3)
        with rtde_server.state.lock:
            rtde_server.state.runtime_state = 4  # PAUSED
        assert len(_poll_until(link, lambda lk, r: len(r) >= 5, 5.0)) >= 5
        with rtde_server.state.lock:
            rtde_server.state.runtime_state = 5  # RESUMING
        resuming = _poll_until(link, lambda lk, r: any(x.state.speed_scaling == 0.0 for x in r),
                               5.0)
        assert resuming and resuming[-1].state.speed_scaling == 0.0
        with rtde_server.state.lock:
            rtde_server.state.runtime_state = 2  # PLAYING again: ramped up, not a jump
        ramp = _poll_until(link, lambda lk, r: any(x.state.speed_scaling >= 0.3 - 1e-9
                                                   for x in r), 10.0)
        values = [x.state.speed_scaling for x in ramp]
        assert values and values[-1] == pytest.approx(0.3)
        assert any(0.0 < v < 0.3 for v in values), values
    finally:
        link.close()


def test_joint_efforts_are_read_from_rtde_currents_and_target_moments(
    rtde_server: FakeRtdeServer,
) -> None:
    """The real ur_rtde reads actual_current, target_current and target_moment from the fake
    controller; the bridge's efforts are the actual currents times the controller's own torque
    per ampere (target moment / target current), nan for a joint without target current yet."""
    with rtde_server.state.lock:
        rtde_server.state.actual_current = (1.0, 5.0, 2.5, 0.4, 0.2, 0.0)
        rtde_server.state.target_current = (1.0, 4.0, 2.0, 0.5, 0.2, 0.0)
        rtde_server.state.target_moment = (10.0, 80.0, 30.0, 5.0, 1.0, 0.0)
    link = _link(UrRtdeArmFactory("127.0.0.1", 100.0, receive_only=True), monitor=True)
    link.start()
    try:
        reports = _poll_until(link, lambda lk, r: len(r) >= 5, timeout=WAIT_S)
        assert reports, f"no reports: {link.status}"
        effort = reports[-1].state.effort
        assert effort[:5] == pytest.approx((10.0, 100.0, 37.5, 4.0, 1.0))
        assert math.isnan(effort[5])
    finally:
        link.close()


def test_control_mode_failing_at_the_dashboard_keeps_the_root_cause(
    rtde_server: FakeRtdeServer,
) -> None:
    link = _link(UrRtdeArmFactory("127.0.0.1", 100.0), monitor=False)
    link.start()
    try:
        _poll_until(link, lambda lk, r: lk.status.phase == "failed", timeout=WAIT_S)
        assert link.status.phase == "failed"
        assert "dashboard" in link.status.last_error, link.status.last_error
        assert link.status.last_error.startswith("connect failed: RuntimeError")
        assert link.status.history[-1] == link.status.last_error  # not "worker exited"
    finally:
        link.close()


def test_a_refused_connection_is_reported_with_its_reason() -> None:
    link = _link(FakeArmSpec(connect_fails=True), monitor=False)
    link.start()
    try:
        _poll_until(link, lambda lk, r: lk.status.phase == "failed", timeout=WAIT_S)
        assert link.status.last_error == (
            "connect failed: ConnectionError: fake arm: connection refused"
        )
    finally:
        link.close()
