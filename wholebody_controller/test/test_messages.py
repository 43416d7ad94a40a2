"""Message ↔ numpy conversions of the node (pure)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from nav_msgs.msg import Odometry
from sensor_msgs.msg import JointState

from wholebody_controller.contact_task import N_VALUES, Phase, TaskOutput
from wholebody_controller.messages import (
    TASK_STATE_FIELDS,
    InputError,
    arm_command,
    command_to_twist,
    joint_positions,
    msg_to_task_state,
    odom_to_base,
    task_state_from_cdr,
    task_state_to_cdr,
    task_state_to_msg,
)


def test_twist_and_arm_commands() -> None:
    command = np.arange(15, dtype=float) / 10
    twist = command_to_twist(command)
    assert (twist.linear.x, twist.linear.y, twist.angular.z) == (0.0, 0.1, 0.2)
    assert (twist.linear.z, twist.angular.x, twist.angular.y) == (0.0, 0.0, 0.0)
    joints = [f"j{i}" for i in range(6)]
    msg = arm_command(command[3:9], joints)
    assert list(msg.data) == pytest.approx(command[3:9].tolist())
    assert msg.layout.dim[0].label == ",".join(joints) and msg.layout.dim[0].size == 6


@pytest.mark.parametrize("yaw", [0.0, 0.7, -2.5, math.pi - 1e-9])
def test_odometry_yaw(yaw: float) -> None:
    msg = Odometry()
    msg.pose.pose.position.x, msg.pose.pose.position.y = 1.5, -2.0
    msg.pose.pose.orientation.z, msg.pose.pose.orientation.w = math.sin(yaw / 2), math.cos(yaw / 2)
    np.testing.assert_allclose(odom_to_base(msg), [1.5, -2.0, yaw], atol=1e-9)


def test_bad_odometry_and_joint_states_are_refused() -> None:
    msg = Odometry()
    msg.pose.pose.position.x = math.nan
    with pytest.raises(InputError, match="non-finite"):
        odom_to_base(msg)
    msg = Odometry()
    msg.pose.pose.orientation.w = 0.0
    with pytest.raises(InputError, match="quaternion"):
        odom_to_base(msg)
    with pytest.raises(InputError, match="non-finite"):
        joint_positions(JointState(name=["a", "b"], position=[0.0, math.inf]))
    with pytest.raises(InputError, match="names"):
        joint_positions(JointState(name=["a", "b"], position=[0.0]))
    assert joint_positions(JointState(name=["a", "b"], position=[0.5, -1.0])) == {
        "a": 0.5, "b": -1.0}


def test_task_state_round_trip_keeps_every_field() -> None:
    # Every value distinct (and exact in binary) so that two swapped fields cannot both match.
    vectors = {name: [base + k / 8 for k in range(size)] for name, base, size in (
        ("point", 10.0, 3), ("target", 20.0, 6), ("control_velocity", 30.0, 6),
        ("wrench", 40.0, 6), ("track_force", 50.0, 3), ("deflection", 60.0, 6),
        ("deflection_velocity", 70.0, 6))}
    error = [80.0 + k / 8 for k in range(6)]
    layout = ("target", "control_velocity", "wrench", "deflection", "deflection_velocity",
              "point", "track_force")  # the order of TaskOutput.values
    values = tuple(v for name in layout for v in vectors[name])
    assert len(values) == N_VALUES
    task = TaskOutput(link="left_forearm_link", phase=Phase.DEACTIVATING, psi=0.25, psi_raw=0.375,
                      in_contact=True, values=values)
    for name in layout:  # the layout above is the one TaskOutput reads
        assert getattr(task, name).tolist() == vectors[name]
    twist, pose, wrench, lin = ("vx", "vy", "vz", "wx", "wy", "wz"), (
        "x", "y", "z", "rx", "ry", "rz"), ("fx", "fy", "fz", "tx", "ty", "tz"), ("x", "y", "z")
    expected = {"psi": 0.25, "psi_raw": 0.375, "phase": 3.0, "in_contact": 1.0}
    for field, axes, values in (
        ("deflection", pose, vectors["deflection"]),
        ("deflection_velocity", twist, vectors["deflection_velocity"]),
        ("wrench", wrench, vectors["wrench"]), ("track_force", lin, vectors["track_force"]),
        ("control_velocity", twist, vectors["control_velocity"]),
        ("tracking_error", twist, error), ("center_link", lin, vectors["point"]),
    ):
        expected.update({f"{field}_{axis}": v for axis, v in zip(axes, values, strict=True)})
    assert len(set(expected.values())) == len(expected), "test values must be distinct"

    msg = task_state_to_msg(task, np.array(error), 123_000_000_456, "odom")
    assert msg.header.frame_id == "odom"
    assert (msg.header.stamp.sec, msg.header.stamp.nanosec) == (123, 456)
    assert [f.name for f in msg.fields] == list(TASK_STATE_FIELDS)
    assert msg_to_task_state(msg) == expected
    from rclpy.serialization import deserialize_message, serialize_message
    from sensor_msgs.msg import PointCloud2

    for frame in ("odom", "world_frame_"):  # either padding after the frame id
        msg.header.frame_id = frame
        assert task_state_from_cdr(serialize_message(msg)) == expected
        # The node publishes the bytes written without the message: rclpy reads them back as it.
        written = task_state_to_cdr(task, np.array(error), 123_000_000_456, frame)
        assert deserialize_message(written, PointCloud2) == msg
        assert len(written) == len(serialize_message(msg))
        assert task_state_from_cdr(written) == expected


def test_task_state_bytes_of_another_layout_are_left_to_the_reference() -> None:
    """task_state_from_cdr reads only the layout task_state_to_msg writes: a cloud with other
    fields (a contact state) or truncated bytes give None (the caller deserializes)."""
    from rclpy.serialization import serialize_message

    from phri_common.contact import contact_to_msg
    from phri_common.records import ContactState

    contact = ContactState("left_forearm_link", 5, True, center=(0.1, 0.0, 0.0),
                           force=(0.0, 5.0, 0.0))
    assert task_state_from_cdr(serialize_message(contact_to_msg(contact))) is None
    task = TaskOutput(link="l", phase=Phase.ACTIVE, psi=1.0, psi_raw=1.0, in_contact=True,
                      values=tuple(0.0 for _ in range(N_VALUES)))
    raw = serialize_message(task_state_to_msg(task, np.zeros(6), 1, "odom"))
    assert task_state_from_cdr(raw) is not None
    assert task_state_from_cdr(raw[:-60]) is None
    assert task_state_from_cdr(b"\x00\x00" + raw[2:]) is None  # big endian: not read here


def test_safety_status_levels() -> None:
    from diagnostic_msgs.msg import DiagnosticStatus

    from wholebody_controller.config import LinkTaskConfig
    from wholebody_controller.contact_safety import Safety
    from wholebody_controller.messages import safety_status
    from wholebody_controller.task_step import guard_update
    from wholebody_controller.tasks import ContactTask

    task = ContactTask(LinkTaskConfig("left_forearm_link"))
    guard_update(task.state, task.params, 30.0)
    ok = safety_status(task, Safety.OK, "wbc")
    assert ok.level == DiagnosticStatus.OK and ok.name == "wbc: contact safety left_forearm_link"
    assert {v.key: v.value for v in ok.values}["force_limit_N"] == "110"
    assert safety_status(task, Safety.CONTACT_LOST, "w").level == DiagnosticStatus.WARN
    assert safety_status(task, Safety.YIELDING, "w").level == DiagnosticStatus.ERROR
    guard_update(task.state, task.params, 250.0)
    status = safety_status(task, Safety.OK, "w")
    assert status.level == DiagnosticStatus.ERROR and "transient" in status.message
