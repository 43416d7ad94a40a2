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


def test_task_state_round_trip() -> None:
    rng = np.random.default_rng(0)
    task = TaskOutput(link="left_forearm_link", phase=Phase.DEACTIVATING, psi=0.3, psi_raw=0.3,
                      in_contact=False, values=tuple(rng.normal(size=N_VALUES).tolist()))
    error = rng.normal(size=6)
    msg = task_state_to_msg(task, error, 123_000_000_456, "odom")
    assert msg.header.frame_id == "odom" and msg.header.stamp.nanosec == 456
    assert [f.name for f in msg.fields] == list(TASK_STATE_FIELDS)
    state = msg_to_task_state(msg)
    assert state["psi"] == 0.3 and state["phase"] == Phase.DEACTIVATING
    assert state["in_contact"] == 0.0
    assert state["track_force_y"] == task.track_force[1]
    assert state["deflection_rz"] == task.deflection[5]
    assert state["tracking_error_wx"] == error[3]
    assert state["center_link_z"] == task.point[2]
