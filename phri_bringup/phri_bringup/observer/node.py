"""The observer node: subscribes every documented topic (raw CDR) and feeds sinks (thin node).

Sinks are the MCAP recorder (:class:`RecordingSink`) and the Foxglove live view
(:mod:`phri_bringup.observer.foxglove`). The node also remembers the last velocity commands (the
runner checks that the last ones were zero) and can pace a lock-step run to the wall clock
(``pace``).
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from typing import Any, Protocol

from geometry_msgs.msg import Twist
from nav_msgs.msg import Odometry
from rclpy.context import Context
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from rclpy.serialization import deserialize_message
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray, String

from phri_bringup.graph.nodes import (
    ARMS,
    RECORDED_EXTRA_TOPICS,
    ROBOT_DESCRIPTION_TOPIC,
    SIM_TOPICS,
    TF_STATIC_TOPIC,
    TF_TOPIC,
    TopicSpec,
    robot_description_urdf,
)
from phri_bringup.observer.bag import McapRecording, encode, ros_type, stamp_ns_of, tf_message
from phri_bringup.observer.link_frames import RobotFrames, split_static
from phri_bringup.observer.recording_process import SkinDecimation
from phri_common.planar import yaw_from_quaternion

COMMAND_TOPICS: dict[str, type[Any]] = {
    "/cmd_vel": Twist,
    **{f"/{arm}/forward_velocity_controller/commands": Float64MultiArray for arm in ARMS},
}


class Sink(Protocol):
    """Receives every observed message."""

    def on_message(self, topic: str, type_name: str, raw: bytes, stamp_ns: int) -> None: ...

    def close(self) -> None: ...


class RobotState:
    """Latest arm joint positions and base pose, decoded from /joint_states and /odom.

    :meth:`update` only keeps the newest message of each (bytes); it is decoded when the state
    is read (:attr:`joint_names`, :attr:`positions`, :attr:`base`): the recorder reads it at
    the /tf rate, below the rate the state arrives at."""

    def __init__(self) -> None:
        self._joint_names: list[str] = []
        self._positions: list[float] = []
        self._base = [0.0, 0.0, 0.0]
        self._raw: dict[str, bytes] = {}

    def update(self, topic: str, raw: bytes) -> bool:
        """Keep a state message; True if ``topic`` carried robot state."""
        if topic not in ("/joint_states", "/odom"):
            return False
        self._raw[topic] = raw
        return True

    def _decode(self) -> None:
        raw = self._raw.pop("/joint_states", None)
        if raw is not None:
            js = deserialize_message(raw, JointState)
            self._joint_names, self._positions = list(js.name), list(js.position)
        raw = self._raw.pop("/odom", None)
        if raw is not None:
            od = deserialize_message(raw, Odometry)
            q = od.pose.pose.orientation
            self._base = [od.pose.pose.position.x, od.pose.pose.position.y,
                          yaw_from_quaternion(q.w, q.x, q.y, q.z)]

    @property
    def joint_names(self) -> list[str]:
        """Names of the newest joint state."""
        self._decode()
        return self._joint_names

    @property
    def positions(self) -> list[float]:
        """Positions of the newest joint state [rad or m]."""
        self._decode()
        return self._positions

    @property
    def base(self) -> list[float]:
        """Base pose of the newest odometry: x [m], y [m], yaw [rad]."""
        self._decode()
        return self._base


class RecordingSink:
    """Writes the observed topics into a rosbag2 MCAP recording (:mod:`phri_bringup.observer.bag`,
    each topic with its offered QoS); taxel arrays at ``skin_rate_hz`` (sim time; 0 = every
    frame); ``/tf`` (moving joints) computed at ``tf_rate_hz`` from the robot state; and at the
    first message ``/robot_description`` (the URDF) and ``/tf_static`` (fixed joints), once each,
    latched — what robot_state_publisher would have published."""

    def __init__(self, directory: str, skin_rate_hz: float = 20.0, tf_rate_hz: float = 50.0
                 ) -> None:
        self.recording = McapRecording(directory)
        for spec in (*SIM_TOPICS, *RECORDED_EXTRA_TOPICS):
            self.recording.declare(spec.name, spec.type)
        self.skin = SkinDecimation(skin_rate_hz)
        self.tf_period_ns = round(1e9 / tf_rate_hz)
        self._last_tf = -math.inf
        self._latched_written = False
        self.state = RobotState()
        self.frames = RobotFrames()

    def _write_latched(self, stamp_ns: int) -> None:
        """``/robot_description`` and ``/tf_static`` once, at the recording's first time."""
        self._latched_written = True
        self.recording.add(ROBOT_DESCRIPTION_TOPIC.name, ROBOT_DESCRIPTION_TOPIC.type,
                           encode(ROBOT_DESCRIPTION_TOPIC.type,
                                  {"data": robot_description_urdf()}), stamp_ns)
        _moving, fixed = split_static(self.frames.transforms())
        self.recording.add(TF_STATIC_TOPIC.name, TF_STATIC_TOPIC.type,
                           encode(TF_STATIC_TOPIC.type, tf_message(fixed, stamp_ns)), stamp_ns)

    def on_message(self, topic: str, type_name: str, raw: bytes, stamp_ns: int) -> None:
        if not self._latched_written:
            self._write_latched(stamp_ns)
        if not self.skin.keep(topic, stamp_ns):
            return
        self.recording.add(topic, type_name, raw, stamp_ns)
        if self.state.update(topic, raw) and stamp_ns - self._last_tf >= self.tf_period_ns:
            self._last_tf = stamp_ns
            self.frames.set_state(self.state.joint_names, self.state.positions, self.state.base)
            moving, _fixed = split_static(self.frames.transforms())
            self.recording.add(TF_TOPIC.name, TF_TOPIC.type,
                               encode(TF_TOPIC.type, tf_message(moving, stamp_ns)), stamp_ns)

    def close(self) -> None:
        self.recording.close()


class ObserverNode(Node):
    """Subscribes ``topics`` raw and hands each message to every sink with its time [ns] (the
    header stamp where the message has one, else the newest time seen); with
    ``robot_description`` it also publishes the URDF on /robot_description (latched), standing in
    for robot_state_publisher in ``phri sim``."""

    def __init__(self, context: Context, sinks: Sequence[Sink], *,
                 topics: Sequence[TopicSpec] = SIM_TOPICS, pace: float | None = None,
                 name: str = "phri_observer", robot_description: str | None = None) -> None:
        super().__init__(name, context=context)
        if robot_description is not None:  # latched, as robot_state_publisher publishes it
            latched = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                                 durability=DurabilityPolicy.TRANSIENT_LOCAL)
            self.description_pub = self.create_publisher(
                String, ROBOT_DESCRIPTION_TOPIC.name, latched)
            self.description_pub.publish(String(data=robot_description))
        self.sinks = list(sinks)
        self.now_ns = 0
        self.pace = pace
        self._wall0: float | None = None
        self.last_commands: dict[str, Any] = {}
        self.message_counts: dict[str, int] = {}
        qos = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE)
        for spec in topics:
            msg_type = ros_type(spec.type)
            self.create_subscription(
                msg_type, spec.name,
                lambda raw, spec=spec: self._on_raw(spec, raw), qos, raw=True,
            )

    def _on_raw(self, spec: TopicSpec, raw: bytes) -> None:
        stamp = stamp_ns_of(spec.type, raw)
        if stamp is not None:
            self.now_ns = max(self.now_ns, stamp)
        t = stamp if stamp is not None else self.now_ns
        self.message_counts[spec.name] = self.message_counts.get(spec.name, 0) + 1
        if spec.name in COMMAND_TOPICS:
            self.last_commands[spec.name] = deserialize_message(raw, COMMAND_TOPICS[spec.name])
        for sink in self.sinks:
            sink.on_message(spec.name, spec.type, raw, t)
        if spec.name == "/clock" and self.pace:
            self._pace(t)

    def _pace(self, sim_ns: int) -> None:
        """Sleep until the wall clock catches up with ``sim_ns`` / pace (lock-step runs only)."""
        now = time.monotonic()
        if self._wall0 is None:
            self._wall0 = now - sim_ns * 1e-9 / float(self.pace or 1.0)
        ahead = self._wall0 + sim_ns * 1e-9 / float(self.pace or 1.0) - now
        if ahead > 0:
            time.sleep(min(ahead, 0.5))

    def last_command_is_zero(self) -> bool:
        """The last /cmd_vel and both arm commands seen were all zero (and all were seen)."""
        if set(self.last_commands) != set(COMMAND_TOPICS):
            return False
        twist = self.last_commands["/cmd_vel"]
        values = [twist.linear.x, twist.linear.y, twist.linear.z,
                  twist.angular.x, twist.angular.y, twist.angular.z]
        for topic, msg in self.last_commands.items():
            if topic != "/cmd_vel":
                values += list(msg.data)
        return all(v == 0.0 for v in values)


