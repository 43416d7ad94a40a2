"""Message ↔ plain-value conversions of the hardware bridges (pure: message types, no rclpy)."""

from __future__ import annotations

import math
from collections.abc import Sequence

from builtin_interfaces.msg import Time
from geometry_msgs.msg import Twist, TwistStamped
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64, Float64MultiArray

from phri_hardware.ur_arm import UR_JOINTS, ArmState


def joint_names(prefix: str) -> list[str]:
    """``left_`` → ``["left_shoulder_pan_joint", …]`` (UR order)."""
    return [f"{prefix}{name}" for name in UR_JOINTS]


def arm_state_to_joint_state(names: Sequence[str], state: ArmState, stamp: Time) -> JointState:
    """JointState with positions [rad], velocities [rad/s] and, once every joint's is known,
    efforts [N·m] (the drives' torques, gravity included) of one arm."""
    msg = JointState()
    msg.header.stamp = stamp
    msg.name = list(names)
    msg.position = [float(x) for x in state.q]
    msg.velocity = [float(x) for x in state.qd]
    if all(math.isfinite(x) for x in state.effort):
        msg.effort = [float(x) for x in state.effort]
    return msg


SPEED_SCALING_TOPIC = "speed_scaling_state_broadcaster/speed_scaling"
"""ur_robot_driver's speed scaling topic (relative: ``/<arm>/…`` in an arm's namespace),
std_msgs/Float64 in percent (docs/hardware.md, "Speed scaling")."""


def speed_scaling_msg(fraction: float) -> Float64:
    """The executed fraction of commanded speed (0–1) as ur_robot_driver publishes it: percent
    0–100 (its speed_scaling_state_broadcaster multiplies the fraction by 100)."""
    return Float64(data=100.0 * float(fraction))


def state_is_finite(state: ArmState) -> bool:
    """True when every position and velocity is a finite number (a real reading)."""
    return all(math.isfinite(x) for x in (*state.q, *state.qd))


def command_values(msg: Float64MultiArray) -> list[float]:
    """The joint velocities of a ``forward_velocity_controller/commands`` message [rad/s]."""
    return [float(x) for x in msg.data]


def twist_to_tuple(msg: Twist) -> tuple[float, float, float, float, float, float]:
    """(v_x, v_y, v_z [m/s], ω_x, ω_y, ω_z [rad/s])."""
    return (float(msg.linear.x), float(msg.linear.y), float(msg.linear.z),
            float(msg.angular.x), float(msg.angular.y), float(msg.angular.z))


def planar_twist(vx: float, vy: float, wz: float) -> Twist:
    """A base twist: linear x, y [m/s], angular z [rad/s], every other component zero."""
    msg = Twist()
    msg.linear.x, msg.linear.y, msg.angular.z = float(vx), float(vy), float(wz)
    return msg


def planar_twist_stamped(vx: float, vy: float, wz: float, frame_id: str,
                         stamp: Time) -> TwistStamped:
    """:func:`planar_twist` with a header (mecanum_drive_controller's reference type)."""
    msg = TwistStamped()
    msg.header.frame_id = frame_id
    msg.header.stamp = stamp
    msg.twist = planar_twist(vx, vy, wz)
    return msg


__all__ = [
    "SPEED_SCALING_TOPIC",
    "arm_state_to_joint_state",
    "command_values",
    "joint_names",
    "planar_twist",
    "planar_twist_stamped",
    "speed_scaling_msg",
    "state_is_finite",
    "twist_to_tuple",
]
