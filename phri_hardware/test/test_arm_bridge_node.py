"""The arm bridge node with the ur_rtde interface faked at the module boundary (worker process)."""

from __future__ import annotations

import json
import time
from collections.abc import Callable
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
ZERO = [0.0] * 6
WAIT_S = 60.0
"""Longest wait for something that must happen (a stalled machine); never a measured time."""


def read_log(path: Path) -> list[dict]:
    if not path.exists():
        return []
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()]


def speed_j_sent(path: Path, qd: list[float]) -> bool:
    """The fake arm has received a speedJ of ``qd``."""
    return any(e["call"] == "speedJ" and e["args"][0] == qd for e in read_log(path))


class Harness:
    """The bridge and a peer node on one executor. Defaults that keep a loaded machine from
    interfering where a test is not about them: commands stay fresh for 2 s (the longest
    command_timeout) and a worker may be silent for 5 s before it is restarted."""

    def __init__(self, context: object, spec: FakeArmSpec | None, **overrides: object) -> None:
        params = {"joint_prefix": "left_", "rate_hz": RATE, "diagnostics_period": 0.2,
                  "watchdog_frequency": 2.0, "command_timeout": 2.0, "report_timeout": 5.0,
                  **overrides}
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

    def run_until(self, condition: Callable[[], bool], qd: list[float] | None,
                  timeout: float = WAIT_S) -> bool:
        """Spin, publishing ``qd`` at the control rate (None = silence), until ``condition()``
        holds; ``timeout`` [s] only bounds a stalled machine."""
        end = time.monotonic() + timeout
        next_pub = time.monotonic()
        while time.monotonic() < end:
            if condition():
                return True
            if qd is not None and time.monotonic() >= next_pub:
                self.cmd_pub.publish(Float64MultiArray(data=qd))
                next_pub = time.monotonic() + 1.0 / RATE
            self.executor.spin_once(timeout_sec=0.002)
        return condition()

    def last_message(self, text: str) -> bool:
        """The newest diagnostic status's message contains ``text``."""
        return bool(self.diagnostics) and text in self.diagnostics[-1].message

    def close(self) -> None:
        self.bridge.destroy_node()
        self.peer.destroy_node()
        self.executor.shutdown()


@pytest.mark.ros
def test_commands_pass_through_and_joint_states_follow(ros_context: object,
                                                       tmp_path: Path) -> None:
    log = tmp_path / "arm.jsonl"
    h = Harness(ros_context, FakeArmSpec(log_path=str(log)), acceleration=40.0,
                command_timeout=0.1)
    try:
        assert spin_until(h.executor, lambda: h.bridge.link.status.phase == "running", WAIT_S)
        assert h.run_until(lambda: speed_j_sent(log, ZERO) and bool(h.joint_states), ZERO)
        assert h.joint_states[-1].name[0] == "left_shoulder_pan_joint"
        q0 = list(h.joint_states[-1].position)

        def moved() -> bool:
            q = h.joint_states[-1].position
            return speed_j_sent(log, QD) and q[0] - q0[0] > 0.01 and q0[5] - q[5] > 0.02

        # The command reaches the arm, and the joint states follow it: joints 0 and 5 move the
        # commanded way, the joints commanded 0 stay where they were (the speeds themselves are
        # test_arm_worker's, on a fake clock).
        assert h.run_until(moved, QD)
        assert list(h.joint_states[-1].position)[1:5] == q0[1:5]
        # A stale command stream stops the arm.
        assert h.run_until(lambda: read_log(log)[-1]["call"] == "speedStop"
                           and h.last_message("command stale"), None)
    finally:
        h.close()
    # shutdown stops the arm: the worker's last calls are speedStop and disconnect
    assert [e["call"] for e in read_log(log)][-2:] == ["speedStop", "disconnect"]


@pytest.mark.ros
def test_shutdown_while_moving_stops_the_arm(ros_context: object, tmp_path: Path) -> None:
    log = tmp_path / "arm.jsonl"
    h = Harness(ros_context, FakeArmSpec(log_path=str(log)))
    try:
        assert spin_until(h.executor, lambda: h.bridge.link.status.phase == "running", WAIT_S)
        assert h.run_until(lambda: speed_j_sent(log, ZERO), ZERO)
        assert h.run_until(lambda: speed_j_sent(log, QD), QD)  # moving: now shut down
    finally:
        h.close()
    entries = read_log(log)
    # Moving until the shutdown (no stop before it), then speedStop and disconnect.
    assert entries[-3]["call"] == "speedJ" and entries[-3]["args"][0] == QD
    assert [e["call"] for e in entries][-2:] == ["speedStop", "disconnect"]


@pytest.mark.ros
def test_a_connection_that_never_answers_does_not_block_the_executor(ros_context: object) -> None:
    # The fake hangs in connect holding the GIL, as ur_rtde does against a silent host.
    h = Harness(ros_context, FakeArmSpec(connect_hangs=True), connect_timeout=1.0,
                restart_delay=0.3)
    try:
        link = h.bridge.link.status
        # The node's timers kept running while the worker hung: they published diagnostics,
        # abandoned the hung connect and retried.
        assert h.run_until(lambda: link.worker_kills >= 1 and link.attempts >= 2 and any(
            "connect did not finish" in s.message for s in h.diagnostics), ZERO)
        during = [s for s in h.diagnostics if _values(s).get("connection_attempts") == "1"]
        assert during, "no diagnostics while the first connect hung"
        assert h.diagnostics[-1].level in (DiagnosticStatus.WARN, DiagnosticStatus.ERROR)
        assert not h.joint_states
    finally:
        h.close()


@pytest.mark.ros
def test_protective_stop_is_reported_and_no_command_is_sent(ros_context: object,
                                                             tmp_path: Path) -> None:
    log = tmp_path / "arm.jsonl"
    pstop = tmp_path / "protective_stop"  # the fake arm is protectively stopped while it exists
    spec = FakeArmSpec(log_path=str(log), protective_stop_file=str(pstop))
    h = Harness(ros_context, spec)
    try:
        assert spin_until(h.executor, lambda: h.bridge.link.status.phase == "running", WAIT_S)
        assert h.run_until(lambda: speed_j_sent(log, ZERO), ZERO)
        assert h.run_until(lambda: speed_j_sent(log, QD), QD)  # moving
        pstop.touch()  # the protective stop starts; the same command keeps coming

        def stopped() -> list[DiagnosticStatus]:
            return [s for s in h.diagnostics if s.message == "protective stop"]

        assert h.run_until(lambda: len(stopped()) >= 3, QD)  # it lasts three reports
        assert all(s.level == DiagnosticStatus.ERROR for s in stopped())
        values = {kv.key: kv.value for kv in stopped()[-1].values}
        assert values["safety_mode"] == "PROTECTIVE_STOP"
        pstop.unlink()  # released: still the old speed → stays disarmed
        assert h.run_until(lambda: h.last_message("disarmed"), QD)
    finally:
        h.close()
    entries = read_log(log)
    # pstop: the protective stop flag of the state the bridge had read before the call.
    assert not [e for e in entries if e["call"] == "speedJ" and e["pstop"]]
    pstop_stops = [e for e in entries if e["call"] == "speedStop" and e["pstop"]]
    assert len(pstop_stops) == 1  # one speedStop at the onset
    assert "reuploadScript" in [e["call"] for e in entries]  # the script restarted after it


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
        assert spin_until(h.executor, lambda: len(h.joint_states) >= 20, WAIT_S)
        js = h.joint_states[-1]
        assert js.name[0] == "left_shoulder_pan_joint"
        assert list(js.position) == pytest.approx(rtde_server.state.q)
        # Published as ur_robot_driver publishes it: percent, with every joint state.
        assert spin_until(h.executor, lambda: len(h.speed_scaling) >= 20, WAIT_S)
        assert h.speed_scaling[-1] == pytest.approx(30.0)
        assert h.run_until(lambda: h.last_message("monitor mode"), None)
        quiet = h.diagnostics[-1]
        assert quiet.level == DiagnosticStatus.OK and "monitor mode" in quiet.message
        assert _values(quiet)["robot_mode"] == "RUNNING"
        assert _values(quiet)["safety_mode"] == "NORMAL"

        def refused() -> bool:  # commands are refused: WARN, counted
            return h.last_message("monitor mode: commands refused") and int(
                _values(h.diagnostics[-1])["commands_refused"]) >= 20

        assert h.run_until(refused, QD)
        assert h.diagnostics[-1].level == DiagnosticStatus.WARN
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
            WAIT_S,
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
        assert spin_until(h.executor, lambda: h.bridge.link.status.phase == "running", WAIT_S)
        assert h.run_until(lambda: h.last_message("moving on command"), ZERO)
        above_cap = [5.0, 0.0, 0.0, 0.0, 0.0, 0.0]  # every one refused

        def refused() -> bool:
            return bool(h.diagnostics) and h.diagnostics[-1].message.startswith(
                "commands refused (zero sent): shoulder_pan_joint")

        assert h.run_until(refused, above_cap)
        assert h.diagnostics[-1].level == DiagnosticStatus.WARN
    finally:
        h.close()
