"""The bridge reports what the arms' drives and safety system report on the robot: the drives'
efforts in ``/joint_states`` and each arm's protective stop on ``/diagnostics`` with the real arm
bridge's name and keys, unlocked through ``sim/<arm>/unlock_protective_stop``."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import qos_profile_sensor_data
from sensor_msgs.msg import JointState
from std_srvs.srv import Trigger

from phri_common.testing import spin_until
from phri_hardware.ur_arm_bridge_node import UrArmBridgeNode
from phri_sim.ros.arm_status import arm_status_name
from phri_sim.ros.bridge import SimBridgeNode

pytestmark = pytest.mark.ros


def _bridge(ros_context: Any) -> SimBridgeNode:
    return SimBridgeNode(context=ros_context, parameter_overrides=[
        Parameter("lockstep", value=True), Parameter("scenario", value="waltz"),
        Parameter("skin_rate_hz", value=100.0), Parameter("physics_timestep", value=0.005)])


def test_joint_states_carry_the_drives_efforts(ros_context: Any) -> None:
    """The held waltz: every joint has an effort; the arms' are the gravity torques their
    drives carry (tens of N·m on the side-mounted arms' first joint), the base's small: only the
    waist's 10 N preload on the forearm."""
    node = _bridge(ros_context)
    peer = Node("effort_probe", context=ros_context)
    executor = SingleThreadedExecutor(context=ros_context)
    executor.add_node(peer)
    states: list[JointState] = []
    peer.create_subscription(JointState, "/joint_states", states.append, qos_profile_sensor_data)
    try:
        def advanced() -> bool:
            node.advance(1, clock=False)
            return len(states) >= 5

        assert spin_until(executor, advanced, timeout_s=60.0)
        last = states[-1]
        effort = dict(zip(last.name, last.effort, strict=True))
        assert len(last.effort) == len(last.name) == 15
        assert abs(effort["left_shoulder_pan_joint"]) > 20.0
        assert abs(effort["base_x"]) < 15.0 and abs(effort["base_y"]) < 15.0
        assert np.all(np.isfinite(last.effort))
    finally:
        executor.shutdown()
        peer.destroy_node()
        node.destroy_node()


def test_arm_status_as_the_real_bridge_reports_it(ros_context: Any) -> None:
    node = _bridge(ros_context)
    peer = Node("diag_probe", context=ros_context)
    executor = SingleThreadedExecutor(context=ros_context)
    executor.add_node(peer)
    seen: list[DiagnosticStatus] = []
    peer.create_subscription(DiagnosticArray, "/diagnostics",
                             lambda msg: seen.extend(msg.status), 10)
    client = peer.create_client(Trigger, "sim/left/unlock_protective_stop")
    real = UrArmBridgeNode(context=ros_context, parameter_overrides=[
        Parameter("backend", value="fake"), Parameter("rate_hz", value=10.0)])
    executor.add_node(real)
    executor.add_node(node)  # its unlock service
    try:
        real_keys = set()

        def real_connected() -> bool:
            status = real.diagnostic_status()
            real_keys.update(v.key for v in status.values)
            return "safety_mode" in real_keys

        assert spin_until(executor, real_connected, timeout_s=60.0)

        def left_status() -> DiagnosticStatus | None:
            node.advance(1, clock=False)
            named = [s for s in seen if s.name == arm_status_name("left")]
            return named[-1] if named else None

        assert spin_until(executor, lambda: left_status() is not None, timeout_s=60.0)
        status = left_status()
        assert status is not None and status.level == DiagnosticStatus.OK
        mirrored = {v.key for v in status.values} - {
            "protective_stops", "last_stop_joint", "last_stop_torque_Nm",
            "last_stop_allowed_Nm", "last_stop_time_s"}
        assert mirrored <= real_keys, mirrored - real_keys
        # A push of 400 N on the unsensed left wrist: the arm protective-stops, ERROR at once.
        wrist = node.sim.model.body("left_wrist_3_link").id
        node.sim.data.xfrc_applied[wrist, 1] = 400.0
        assert spin_until(executor, lambda: (s := left_status()) is not None
                          and s.level == DiagnosticStatus.ERROR, timeout_s=60.0)
        stopped = [s for s in seen if s.name == arm_status_name("left")][-1]
        values = {v.key: v.value for v in stopped.values}
        assert stopped.message == "protective stop"
        assert values["safety_mode"] == "PROTECTIVE_STOP" and values["protective_stopped"] == "True"
        assert client.wait_for_service(timeout_sec=10.0)
        future = client.call_async(Trigger.Request())
        assert spin_until(executor, future.done, timeout_s=60.0)
        result = future.result()
        assert result is not None and not result.success and "5s" in result.message
    finally:
        executor.shutdown()
        real.destroy_node()
        peer.destroy_node()
        node.destroy_node()
