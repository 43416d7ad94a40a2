"""ROS 2 node: one UR arm over RTDE (ur_rtde) ↔ ``forward_velocity_controller/commands``.

Run one per arm in the arm's namespace (``left`` / ``right``) with ``joint_prefix`` ``left_`` /
``right_``. Interface (docs/hardware.md):

* subscribes ``forward_velocity_controller/commands`` (std_msgs/Float64MultiArray, 6 joint
  velocities [rad/s] in UR order);
* publishes ``/joint_states`` (sensor_msgs/JointState, ``<joint_prefix><ur joint>``) once per
  control period from RTDE receive;
* publishes ``speed_scaling_state_broadcaster/speed_scaling`` (std_msgs/Float64, percent 0–100,
  as ur_robot_driver does) with each joint state: the fraction of every commanded speed the
  robot executes (the teach pendant's speed slider × the trajectory limiter, ramped after a
  pause), which the controller takes into account;
* publishes ``/diagnostics`` (robot mode, safety mode, connection, counters).

``mode: monitor`` opens RTDE receive only: joint states and robot/safety mode are published,
every command is refused (counted, logged, diagnostics WARN) and nothing is ever sent to the arm
(bring-up dry runs; docs/bringup_guide.md).

The node only forwards and publishes: ur_rtde runs in a worker process
(:mod:`phri_hardware.arm_worker`) and the decisions are
:class:`phri_hardware.ur_arm.ArmSupervisor`'s, so nothing here ever waits on the robot.
"""

from __future__ import annotations

import sys
import time
from typing import Any

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from rclpy.node import Node
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64, Float64MultiArray

from phri_common import paper
from phri_common.params import ParamSpec, ParamValue
from phri_common.ros_main import run_nodes
from phri_common.ros_params import declare_parameters
from phri_hardware.arm_worker import ArmFactory, ArmLink, WorkerReport
from phri_hardware.fake_arm import FakeArmSpec
from phri_hardware.messages import (
    SPEED_SCALING_TOPIC,
    arm_state_to_joint_state,
    command_values,
    joint_names,
    speed_scaling_msg,
    state_is_finite,
)
from phri_hardware.rtde_arm import UrRtdeArmFactory
from phri_hardware.ur_arm import (
    UR16E_VELOCITY_LIMITS,
    BridgeConfig,
    RobotMode,
    SafetyMode,
    mode_name,
    robot_fault,
)

BACKENDS = ("ur_rtde", "fake")
MODES = ("control", "monitor")

PARAMS: list[ParamSpec] = [
    ParamSpec("backend", "ur_rtde", "arm interface: ur_rtde (the robot) or fake (a simulated "
              "arm for dry runs without a robot)", read_only=True),
    ParamSpec("mode", "control", "control: commands move the arm (RTDE receive + control); "
              "monitor: RTDE receive only, joint states and robot/safety mode published, every "
              "command refused (bring-up dry runs)", read_only=True),
    ParamSpec("robot_ip", "", "IP address or host name of the UR controller (required for "
              "backend ur_rtde)", read_only=True),
    ParamSpec("rtde_frequency", -1.0, "RTDE frequency; -1 = the robot's own (500 Hz on "
              "e-Series)", unit="Hz", low=-1.0, high=500.0, read_only=True),
    ParamSpec("joint_prefix", "", "prefix of the published joint names (left_ / right_)",
              read_only=True),
    ParamSpec("rate_hz", paper.CONTROL_RATE_HZ,
              "speedJ and /joint_states rate (the controller rate)",
              unit="Hz", low=1.0, high=500.0, read_only=True),
    ParamSpec("command_timeout", 0.1, "a command older than this is stale → speedStop",
              unit="s", low=0.002, high=2.0, read_only=True),
    ParamSpec("acceleration", 2.0, "speedJ joint acceleration", unit="rad/s²", low=0.1,
              high=40.0, read_only=True),
    ParamSpec("stop_deceleration", 4.0, "speedStop joint deceleration", unit="rad/s²",
              low=0.1, high=40.0, read_only=True),
    ParamSpec("velocity_cap", 0.3, "largest accepted joint speed, on top of the UR16e limits "
              "(120°/s shoulder, 180°/s others); a command above it is refused (zero velocity)",
              unit="rad/s", low=0.0, high=3.15, read_only=True),
    ParamSpec("rearm_velocity", 0.01, "after start-up or a fault, motion starts only on a fresh "
              "command whose joint speeds are all below this", unit="rad/s", low=0.0, high=0.5,
              read_only=True),
    ParamSpec("allow_reduced_safety", False, "also move in the REDUCED safety mode (else only "
              "NORMAL)", read_only=True),
    ParamSpec("watchdog_frequency", 10.0, "ur_rtde watchdog: the robot stops when the bridge "
              "sends nothing at this rate (0 = off)", unit="Hz", low=0.0, high=500.0,
              read_only=True),
    ParamSpec("connect_timeout", 10.0, "a connection attempt that takes longer is abandoned "
              "(worker killed) and retried", unit="s", low=0.5, high=600.0, read_only=True),
    ParamSpec("report_timeout", 0.5, "a connected worker silent this long is killed and "
              "restarted", unit="s", low=0.05, high=60.0, read_only=True),
    ParamSpec("restart_delay", 2.0, "wait before the next connection attempt", unit="s",
              low=0.1, high=600.0, read_only=True),
    ParamSpec("diagnostics_period", 1.0, "period of /diagnostics", unit="s", low=0.05,
              high=60.0, read_only=True),
]


def bridge_config_from_values(values: dict[str, ParamValue]) -> BridgeConfig:
    """Parameter values → decision-logic configuration."""
    return BridgeConfig(
        rate_hz=float(values["rate_hz"]),
        command_timeout=float(values["command_timeout"]),
        acceleration=float(values["acceleration"]),
        stop_deceleration=float(values["stop_deceleration"]),
        velocity_cap=float(values["velocity_cap"]),
        joint_velocity_limits=UR16E_VELOCITY_LIMITS,
        rearm_velocity=float(values["rearm_velocity"]),
        allow_reduced_safety=bool(values["allow_reduced_safety"]),
    )


def factory_from_values(values: dict[str, ParamValue]) -> ArmFactory:
    """The arm factory the parameters ask for (ValueError naming the parameter otherwise)."""
    backend = str(values["backend"])
    if backend not in BACKENDS:
        raise ValueError(f"parameter 'backend' refused value {backend!r}: allowed one of "
                         f"{BACKENDS}")
    if backend == "fake":
        return FakeArmSpec()
    host = str(values["robot_ip"]).strip()
    if not host:
        raise ValueError("parameter 'robot_ip' refused value '': allowed the UR controller's "
                         "IP address or host name (required for backend ur_rtde)")
    return UrRtdeArmFactory(host, float(values["rtde_frequency"]), monitor_mode(values))


def monitor_mode(values: dict[str, ParamValue]) -> bool:
    """True for ``mode: monitor`` (ValueError naming the parameter for an unknown mode)."""
    mode = str(values["mode"])
    if mode not in MODES:
        raise ValueError(f"parameter 'mode' refused value {mode!r}: allowed one of {MODES}")
    return mode == "monitor"


class UrArmBridgeNode(Node):
    """One UR arm: commands in, speedJ out, joint states and diagnostics back.

    Args:
        arm_factory: replaces the factory chosen by ``backend`` (tests inject fakes).
        kwargs: passed to ``rclpy.node.Node`` (``context``, ``namespace``, overrides …).
    """

    def __init__(self, arm_factory: ArmFactory | None = None, **kwargs: Any) -> None:
        super().__init__("ur_arm_bridge", **kwargs)
        self._values = declare_parameters(self, PARAMS)
        self._config = bridge_config_from_values(self._values)
        self._monitor = monitor_mode(self._values)
        factory = arm_factory if arm_factory is not None else factory_from_values(self._values)
        self._names = joint_names(str(self._values["joint_prefix"]))
        self._hardware_id = str(self._values["robot_ip"]) or str(self._values["backend"])
        self._link = ArmLink(
            factory, self._config,
            connect_timeout=float(self._values["connect_timeout"]),
            report_timeout=float(self._values["report_timeout"]),
            restart_delay=float(self._values["restart_delay"]),
            watchdog_frequency=float(self._values["watchdog_frequency"]),
            monitor=self._monitor,
        )
        self._js_pub = self.create_publisher(JointState, "/joint_states", 10)
        self._scaling_pub = self.create_publisher(Float64, SPEED_SCALING_TOPIC, 10)
        self._diag_pub = self.create_publisher(DiagnosticArray, "/diagnostics", 10)
        self._sub = self.create_subscription(
            Float64MultiArray, "forward_velocity_controller/commands", self._on_command, 10
        )
        self._last_phase = ""
        self._refused_seen = 0
        self._last_refusal_mono = -float("inf")  # when a command was last refused
        self._monitor_refused = 0
        self._joint_states_published = 0
        self._link.start()
        self._poll_timer = self.create_timer(self._config.period, self._poll)
        self._diag_timer = self.create_timer(
            float(self._values["diagnostics_period"]), self._publish_diagnostics
        )
        self.get_logger().info(
            f"UR arm bridge for {self._hardware_id} ({self._values['mode']} mode): joints "
            f"{self._names[0]} …, {self._config.rate_hz:g} Hz, cap "
            f"{self._config.velocity_cap:g} rad/s"
        )

    def _on_command(self, msg: Float64MultiArray) -> None:
        if self._monitor:
            self._monitor_refused += 1
            self._last_refusal_mono = time.monotonic()
            self.get_logger().warning(
                "monitor mode: command refused (receive only, nothing is sent to the arm)",
                throttle_duration_sec=1.0,
            )
            return
        # Validation is the supervisor's (in the worker): one place decides what is refused.
        self._link.send_command(command_values(msg), time.monotonic())

    def _poll(self) -> None:
        reports = self._link.poll()
        status = self._link.status
        if status.phase != self._last_phase:
            self._last_phase = status.phase
            text = f"arm link: {status.phase}"
            if status.last_error:
                text += f" ({status.last_error})"
            if status.phase == "failed":
                self.get_logger().error(text)
            else:
                self.get_logger().info(text)
        if not reports:
            return
        newest = reports[-1]
        if newest.counters.refused > self._refused_seen:
            self._refused_seen = newest.counters.refused
            self._last_refusal_mono = time.monotonic()
            self.get_logger().warning(
                f"command refused (zero velocity sent): {newest.counters.last_refusal}",
                throttle_duration_sec=1.0,
            )
        if state_is_finite(newest.state):
            stamp = self.get_clock().now().to_msg()
            self._js_pub.publish(arm_state_to_joint_state(self._names, newest.state, stamp))
            self._scaling_pub.publish(speed_scaling_msg(newest.state.speed_scaling))
            self._joint_states_published += 1

    def diagnostic_status(self) -> DiagnosticStatus:
        """The bridge's current diagnostic status (also published on /diagnostics)."""
        status = self._link.status
        report: WorkerReport | None = status.report
        values = [
            KeyValue(key="mode", value=str(self._values["mode"])),
            KeyValue(key="link_phase", value=status.phase),
            KeyValue(key="connection_attempts", value=str(status.attempts)),
            KeyValue(key="last_error", value=status.last_error),
            KeyValue(key="worker_kills", value=str(status.worker_kills)),
            KeyValue(key="commands_dropped", value=str(status.commands_dropped)),
        ]
        if status.phase != "running" or report is None:
            first_attempt = status.phase == "connecting" and status.attempts == 1
            level = DiagnosticStatus.WARN if first_attempt else DiagnosticStatus.ERROR
            message = f"not connected ({status.phase}): {status.last_error or 'connecting'}"
        else:
            values += self._report_values(report)
            level, message = self._level_and_message(report)
        return DiagnosticStatus(
            level=level, name=f"{self.get_fully_qualified_name()}: UR arm",
            hardware_id=self._hardware_id, message=message, values=values,
        )

    def _level_and_message(self, report: WorkerReport) -> tuple[bytes, str]:
        """Level and message while connected: fault > refused commands > holding > OK."""
        fault = robot_fault(report.state, self._config.allow_reduced_safety,
                            need_program=not self._monitor)
        window = float(self._values["diagnostics_period"])
        refusing = time.monotonic() - self._last_refusal_mono <= window
        if fault is not None:
            return DiagnosticStatus.ERROR, fault
        if self._monitor:
            if refusing:
                return DiagnosticStatus.WARN, (
                    f"monitor mode: commands refused ({self._monitor_refused} so far)"
                )
            return DiagnosticStatus.OK, "monitor mode: receive only"
        if refusing:
            return DiagnosticStatus.WARN, (
                f"commands refused (zero sent): {report.counters.last_refusal}"
            )
        if report.hold_reason:
            return DiagnosticStatus.WARN, report.hold_reason
        return DiagnosticStatus.OK, "moving on command"

    def _report_values(self, report: WorkerReport) -> list[KeyValue]:
        state = report.state
        refused = self._monitor_refused if self._monitor else report.counters.refused
        return [
            KeyValue(key="robot_mode", value=mode_name(RobotMode, state.robot_mode)),
            KeyValue(key="safety_mode", value=mode_name(SafetyMode, state.safety_mode)),
            KeyValue(key="protective_stopped", value=str(state.protective_stopped)),
            KeyValue(key="emergency_stopped", value=str(state.emergency_stopped)),
            KeyValue(key="program_running", value=str(state.program_running)),
            KeyValue(key="speed_scaling", value=f"{100.0 * state.speed_scaling:.0f} %"),
            KeyValue(key="armed", value=str(report.armed)),
            KeyValue(key="moving", value=str(report.moving)),
            KeyValue(key="hold_reason", value=report.hold_reason),
            KeyValue(key="commands", value=str(report.counters.commands)),
            KeyValue(key="commands_refused", value=str(refused)),
            KeyValue(key="last_refusal", value=report.counters.last_refusal),
            KeyValue(key="speedj_sent", value=str(report.counters.speed_j)),
            KeyValue(key="speedstop_sent", value=str(report.counters.speed_stop)),
            KeyValue(key="stale_stops", value=str(report.counters.stale_stops)),
            KeyValue(key="fault_stops", value=str(report.counters.fault_stops)),
            KeyValue(key="loop_overruns", value=str(report.overruns)),
            KeyValue(key="send_failures", value=str(report.send_failures)),
        ]

    def _publish_diagnostics(self) -> None:
        msg = DiagnosticArray(status=[self.diagnostic_status()])
        msg.header.stamp = self.get_clock().now().to_msg()
        self._diag_pub.publish(msg)

    @property
    def link(self) -> ArmLink:
        """The worker handle (tests and diagnostics)."""
        return self._link

    def destroy_node(self) -> None:
        """Stop the arm (the worker sends speedStop and disconnects), then destroy the node."""
        link = getattr(self, "_link", None)  # absent when a parameter was refused in __init__
        if link is not None:
            link.close()
        super().destroy_node()


def main(args: list[str] | None = None) -> None:
    """Entry point ``ur_arm_bridge_node``: run until Ctrl-C or SIGTERM, then stop the arm."""
    sys.exit(run_nodes(lambda: [UrArmBridgeNode()], "ur_arm_bridge", args))


__all__ = ["PARAMS", "UrArmBridgeNode", "bridge_config_from_values", "factory_from_values",
           "main", "monitor_mode"]
