"""The arm bridge node with the ur_rtde interface faked at the module boundary (worker process)."""

from __future__ import annotations

import json
import time
from pathlib import Path

import pytest
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64, Float64MultiArray

from phri_common.params import ParameterValueError
from phri_common.testing import spin_until
from phri_hardware.fake_arm import FakeArmSpec
from phri_hardware.fake_rtde import I_SETUP_INPUTS, FakeRtdeServer
from phri_hardware.ur_arm_bridge_node import UrArmBridgeNode

RATE = 100.0
QD = [0.1, 0.0, 0.0, 0.0, 0.0, -0.2]


def read_log(path: Path) -> list[dict]:
    if not path.exists():
        return []
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()]


class Harness:
    def __init__(self, context: object, spec: FakeArmSpec | None, **overrides: object) -> None:
        params = {"joint_prefix": "left_", "rate_hz": RATE, "diagnostics_period": 0.2,
                  "watchdog_frequency": 2.0, **overrides}
        self.bridge = UrArmBridgeNode(
            arm_factory=spec, context=context, namespace="left",
            parameter_overrides=[Parameter(k, value=v) for k, v in params.items()],
        )
        self.peer = Node("peer", context=context)
        self.cmd_pub = self.peer.create_publisher(
            Float64MultiArray, "/left/forward_velocity_controller/commands", 10)
        self.joint_states: list[JointState] = []
        self.diagnostics: list[DiagnosticStatus] = []
        self.speed_scaling: list[float] = []
        self.peer.create_subscription(JointState, "/joint_states", self.joint_states.append, 50)
        self.peer.create_subscription(  # ur_robot_driver's topic, in the arm's namespace
            Float64, "/left/speed_scaling_state_broadcaster/speed_scaling",
            lambda m: self.speed_scaling.append(m.data), 50)
        self.peer.create_subscription(
            DiagnosticArray, "/diagnostics",
            lambda m: self.diagnostics.extend(s for s in m.status if "UR arm" in s.name), 10)
        self.executor = SingleThreadedExecutor(context=context)  # type: ignore[arg-type]
        self.executor.add_node(self.bridge)
        self.executor.add_node(self.peer)

    def run(self, duration: float, qd: list[float] | None) -> None:
        """Spin for ``duration`` [s], publishing ``qd`` at the control rate (None = silence)."""
        end = time.monotonic() + duration
        next_pub = time.monotonic()
        while time.monotonic() < end:
            if qd is not None and time.monotonic() >= next_pub:
                self.cmd_pub.publish(Float64MultiArray(data=qd))
                next_pub += 1.0 / RATE
            self.executor.spin_once(timeout_sec=0.002)

    def close(self) -> None:
        self.bridge.destroy_node()
        self.peer.destroy_node()
        self.executor.shutdown()


@pytest.mark.ros
def test_commands_pass_through_and_joint_states_follow(ros_context: object,
                                                       tmp_path: Path) -> None:
    log = tmp_path / "arm.jsonl"
    h = Harness(ros_context, FakeArmSpec(log_path=str(log)), acceleration=40.0)
    try:
        assert spin_until(h.executor, lambda: h.bridge.link.status.phase == "running", 10.0)
        h.run(0.3, [0.0] * 6)  # arm with a zero command
        assert h.joint_states, "no /joint_states"
        assert h.joint_states[-1].name[0] == "left_shoulder_pan_joint"
        q0, t0 = list(h.joint_states[-1].position), time.monotonic()
        n0 = sum(1 for e in read_log(log) if e["call"] == "speedJ")
        h.run(1.0, QD)
        q1, elapsed = list(h.joint_states[-1].position), time.monotonic() - t0
        speedj = [e for e in read_log(log) if e["call"] == "speedJ"]
        assert len(speedj) - n0 >= 0.6 * RATE * 1.0  # loosely at the controller rate
        assert speedj[-1]["args"][0] == pytest.approx(QD)
        for j in (0, 5):  # positions integrate the commanded speed (joint states follow)
            assert q1[j] - q0[j] == pytest.approx(QD[j] * elapsed, abs=0.3 * abs(QD[j]) * elapsed)
        # a stale command stream stops the arm
        h.run(0.5, None)
        calls = [e["call"] for e in read_log(log)]
        assert calls[-1] == "speedStop"
        assert any(s.message == "command stale" for s in h.diagnostics[-2:])
    finally:
        h.close()
    # shutdown stops the arm: the worker's last calls are speedStop and disconnect
    assert [e["call"] for e in read_log(log)][-2:] == ["speedStop", "disconnect"]


@pytest.mark.ros
def test_shutdown_while_moving_stops_the_arm(ros_context: object, tmp_path: Path) -> None:
    log = tmp_path / "arm.jsonl"
    h = Harness(ros_context, FakeArmSpec(log_path=str(log)))
    try:
        assert spin_until(h.executor, lambda: h.bridge.link.status.phase == "running", 10.0)
        h.run(0.2, [0.0] * 6)
        h.run(0.3, QD)
        assert read_log(log)[-1]["call"] == "speedJ"
    finally:
        h.close()
    assert [e["call"] for e in read_log(log)][-2:] == ["speedStop", "disconnect"]


@pytest.mark.ros
def test_a_connection_that_never_answers_does_not_block_the_executor(ros_context: object) -> None:
    # The fake hangs in connect holding the GIL, as ur_rtde does against a silent host.
    h = Harness(ros_context, FakeArmSpec(connect_hangs=True), connect_timeout=1.0,
                restart_delay=0.3)
    try:
        t0 = time.monotonic()
        h.run(2.5, [0.0] * 6)
        elapsed = time.monotonic() - t0
        assert len(h.diagnostics) >= 0.6 * elapsed / 0.2  # the node kept spinning
        assert h.bridge.link.status.worker_kills >= 1  # the hung connect was abandoned …
        assert h.bridge.link.status.attempts >= 2  # … and retried
        assert h.diagnostics[-1].level in (DiagnosticStatus.WARN, DiagnosticStatus.ERROR)
        assert not h.joint_states
        assert any("connect did not finish" in s.message for s in h.diagnostics)
    finally:
        h.close()


@pytest.mark.ros
def test_protective_stop_is_reported_and_no_command_is_sent(ros_context: object,
                                                             tmp_path: Path) -> None:
    log = tmp_path / "arm.jsonl"
    spec = FakeArmSpec(log_path=str(log), protective_stop_at=0.8, protective_stop_for=1.0)
    h = Harness(ros_context, spec)
    try:
        assert spin_until(h.executor, lambda: h.bridge.link.status.phase == "running", 10.0)
        h.run(0.2, [0.0] * 6)
        h.run(1.6, QD)  # the protective stop starts 0.8 s after connect and lasts 1 s
        stopped = [s for s in h.diagnostics if s.message == "protective stop"]
        assert stopped and all(s.level == DiagnosticStatus.ERROR for s in stopped)
        values = {kv.key: kv.value for kv in stopped[-1].values}
        assert values["safety_mode"] == "PROTECTIVE_STOP"
        h.run(1.0, QD)  # released: still the old speed → stays disarmed
        assert "disarmed" in h.diagnostics[-1].message
    finally:
        h.close()
    entries = read_log(log)
    assert not [e for e in entries if e["call"] == "speedJ" and e["pstop"]]
    pstop_stops = [e for e in entries if e["call"] == "speedStop" and e["pstop"]]
    assert len(pstop_stops) == 1  # one speedStop at the onset


@pytest.mark.ros
def test_parameters_are_validated(ros_context: object) -> None:
    with pytest.raises(ParameterValueError, match="velocity_cap"):
        UrArmBridgeNode(arm_factory=FakeArmSpec(), context=ros_context,
                        parameter_overrides=[Parameter("velocity_cap", value=5.0)])
    with pytest.raises(ValueError, match="robot_ip"):
        UrArmBridgeNode(context=ros_context)  # backend ur_rtde without an address


def _values(status: DiagnosticStatus) -> dict[str, str]:
    return {kv.key: kv.value for kv in status.values}


@pytest.mark.ros
def test_monitor_mode_publishes_joint_states_from_rtde_and_refuses_commands(
    ros_context: object, rtde_server: FakeRtdeServer
) -> None:
    # The real ur_rtde RTDEReceiveInterface (in the worker) against the fake RTDE server.
    h = Harness(ros_context, None, backend="ur_rtde", robot_ip="127.0.0.1",
                rtde_frequency=100.0, mode="monitor")
    try:
        with rtde_server.state.lock:  # the pendant's slider at 30 %
            rtde_server.state.target_speed_fraction = 0.3
        assert spin_until(h.executor, lambda: len(h.joint_states) >= 20, 15.0)
        js = h.joint_states[-1]
        assert js.name[0] == "left_shoulder_pan_joint"
        assert list(js.position) == pytest.approx(rtde_server.state.q)
        # Published as ur_robot_driver publishes it: percent, with every joint state.
        assert spin_until(h.executor, lambda: len(h.speed_scaling) >= 20, 5.0)
        assert h.speed_scaling[-1] == pytest.approx(30.0)
        h.run(0.5, None)
        quiet = h.diagnostics[-1]
        assert quiet.level == DiagnosticStatus.OK and "monitor mode" in quiet.message
        assert _values(quiet)["robot_mode"] == "RUNNING"
        assert _values(quiet)["safety_mode"] == "NORMAL"
        h.run(0.6, QD)  # commands are refused: WARN, and nothing reaches the robot
        warned = h.diagnostics[-1]
        assert warned.level == DiagnosticStatus.WARN
        assert "monitor mode: commands refused" in warned.message
        assert int(_values(warned)["commands_refused"]) >= 20
        assert h.bridge.link.status.commands_dropped == 0  # refused before the worker
    finally:
        h.close()
    assert I_SETUP_INPUTS not in rtde_server.received  # no input recipe: no command channel


@pytest.mark.ros
def test_control_mode_failing_at_the_dashboard_reports_the_root_cause(
    ros_context: object, rtde_server: FakeRtdeServer
) -> None:
    h = Harness(ros_context, None, backend="ur_rtde", robot_ip="127.0.0.1",
                rtde_frequency=100.0, restart_delay=5.0)
    try:
        assert spin_until(
            h.executor,
            lambda: any(s.level == DiagnosticStatus.ERROR for s in h.diagnostics),
            15.0,
        )
        failed = next(s for s in h.diagnostics if s.level == DiagnosticStatus.ERROR)
        assert "dashboard" in failed.message, failed.message
        assert "dashboard" in _values(failed)["last_error"]
        assert not h.joint_states  # control mode needs both interfaces
    finally:
        h.close()


@pytest.mark.ros
def test_refused_commands_turn_the_status_warn(ros_context: object) -> None:
    h = Harness(ros_context, FakeArmSpec())
    try:
        assert spin_until(h.executor, lambda: h.bridge.link.status.phase == "running", 10.0)
        h.run(0.3, [0.0] * 6)
        assert h.diagnostics[-1].message == "moving on command"
        h.run(0.6, [5.0, 0.0, 0.0, 0.0, 0.0, 0.0])  # above the velocity cap: every one refused
        refused = h.diagnostics[-1]
        assert refused.level == DiagnosticStatus.WARN
        assert refused.message.startswith("commands refused (zero sent): shoulder_pan_joint")
    finally:
        h.close()
