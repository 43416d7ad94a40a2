"""Live view without a ROS install: a Foxglove WebSocket server (foxglove-sdk).

``phri sim --foxglove`` adds a :class:`FoxgloveSink` to the observer: it serves
``ws://127.0.0.1:8765`` (localhost only) and streams, in Foxglove's own schemas,

| channel | schema | content |
|---|---|---|
| ``/tf`` | FrameTransforms | every link frame, the URDF's tree (/joint_states, /odom) |
| ``/robot`` | SceneUpdate | the robot's primitives (phri_description geoms), frame-locked |
| ``/skin/<patch>`` | PointCloud | taxels and their forces (colour by ``force``), link frames |
| ``/contacts`` | SceneUpdate | per touched link: contact centre (sphere), force (arrow, the push) |
| ``/person`` | SceneUpdate | the simulated person's torso and hands |

Open Foxglove (app or https://app.foxglove.dev) or Lichtblick → *Open connection* → *Foxglove
WebSocket* → ``ws://localhost:8765``, add a 3D panel and set its display frame to ``odom``.
Clients offering either subprotocol, ``foxglove.sdk.v1`` (current Foxglove) or
``foxglove.websocket.v1`` (Lichtblick, older Foxglove builds), are served
(:mod:`phri_bringup.observer.foxglove_relay`).
Streams are throttled to ``rate_hz`` (sim time) per channel.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from phri_bringup.graph.nodes import PATCHES, SKIN_LINKS
from phri_bringup.observer.link_frames import RobotFrames, Transform
from phri_bringup.observer.node import RobotState

DEFAULT_PORT = 8765
ROBOT_REPEAT_S = 2.0
"""The static robot geometry is sent again this often [s] (sim time) for late viewers."""


def _quat_from_matrix(rot: np.ndarray) -> tuple[float, float, float, float]:
    """(w, x, y, z) of a rotation matrix."""
    import mujoco

    q = np.zeros(4)
    mujoco.mju_mat2Quat(q, np.ascontiguousarray(rot, dtype=np.float64).reshape(9))
    return float(q[0]), float(q[1]), float(q[2]), float(q[3])


def arrow_orientation(direction: np.ndarray) -> tuple[float, float, float, float]:
    """(w, x, y, z) rotating +x onto ``direction`` (Foxglove arrows point along +x)."""
    d = np.asarray(direction, dtype=np.float64)
    n = float(np.linalg.norm(d))
    if n < 1e-12:
        return 1.0, 0.0, 0.0, 0.0
    d = d / n
    x = np.array([1.0, 0.0, 0.0])
    axis = np.cross(x, d)
    s, c = float(np.linalg.norm(axis)), float(x @ d)
    if s < 1e-12:
        return (1.0, 0.0, 0.0, 0.0) if c > 0 else (0.0, 0.0, 0.0, 1.0)
    angle = math.atan2(s, c)
    axis = axis / s
    h = 0.5 * angle
    return math.cos(h), *(float(a) * math.sin(h) for a in axis)  # type: ignore[return-value]


class FoxgloveSink:
    """Streams the robot, skins and contacts to Foxglove / Lichtblick (module docstring)."""

    def __init__(self, port: int = DEFAULT_PORT, rate_hz: float = 20.0,
                 host: str = "127.0.0.1") -> None:
        import foxglove
        from foxglove.channels import (
            FrameTransformsChannel,
            PointCloudChannel,
            SceneUpdateChannel,
        )

        from phri_bringup.observer.foxglove_relay import SubprotocolRelay

        self.fg = foxglove
        self.context = foxglove.Context()
        # The SDK server listens on a free loopback port; clients connect through the relay,
        # which also accepts the older subprotocol name (phri_bringup.observer.foxglove_relay).
        self.server = foxglove.start_server(name="phri", host="127.0.0.1", port=0,
                                            context=self.context)
        self.relay = SubprotocolRelay(int(self.server.port), host=host, port=port)
        self.port = self.relay.port
        ctx = self.context
        self.tf = FrameTransformsChannel("/tf", context=ctx)
        self.robot = SceneUpdateChannel("/robot", context=ctx)
        self.contacts = SceneUpdateChannel("/contacts", context=ctx)
        self.person = SceneUpdateChannel("/person", context=ctx)
        self.skins = {p: PointCloudChannel(f"/skin/{p}", context=ctx) for p in PATCHES}
        self.period_ns = round(1e9 / rate_hz)
        self._last: dict[str, int] = {}
        self._last_robot = -math.inf
        self.state = RobotState()
        self.frames = RobotFrames()
        self._robot_update = self._robot_scene()
        self.closed = False

    @property
    def url(self) -> str:
        return f"ws://localhost:{self.port}"

    # -- messages -------------------------------------------------------------------------------
    def _due(self, key: str, stamp_ns: int) -> bool:
        last = self._last.get(key)
        if last is not None and stamp_ns - last < self.period_ns:
            return False
        self._last[key] = stamp_ns
        return True

    def _timestamp(self, stamp_ns: int) -> Any:
        return self.fg.messages.Timestamp(sec=stamp_ns // 1_000_000_000,
                                          nsec=stamp_ns % 1_000_000_000)

    def on_message(self, topic: str, type_name: str, raw: bytes, stamp_ns: int) -> None:
        if self.closed:
            return
        if self.state.update(topic, raw):
            if self._due("tf", stamp_ns):
                self.frames.set_state(self.state.joint_names, self.state.positions,
                                      self.state.base)
                self._log_tf(self.frames.transforms(), stamp_ns)
            if stamp_ns * 1e-9 - self._last_robot >= ROBOT_REPEAT_S:
                self._last_robot = stamp_ns * 1e-9
                self.robot.log(self._robot_update, log_time=stamp_ns)
        elif topic.startswith("/skin/") and self._due(topic, stamp_ns):
            self._log_skin(topic.split("/")[2], raw, stamp_ns)
        elif topic.startswith("/contacts/") and topic != "/contacts/markers" \
                and self._due(topic, stamp_ns):
            self._log_contact(raw, stamp_ns)
        elif topic == "/sim/person/poses" and self._due(topic, stamp_ns):
            self._log_person(raw, stamp_ns)

    def _log_tf(self, transforms: list[Transform], stamp_ns: int) -> None:
        m = self.fg.messages
        ts = self._timestamp(stamp_ns)
        self.tf.log(m.FrameTransforms(transforms=[
            m.FrameTransform(
                timestamp=ts, parent_frame_id=t.parent, child_frame_id=t.child,
                translation=m.Vector3(x=t.translation[0], y=t.translation[1],
                                      z=t.translation[2]),
                rotation=m.Quaternion(w=t.rotation[0], x=t.rotation[1], y=t.rotation[2],
                                      z=t.rotation[3]),
            )
            for t in transforms
        ]), log_time=stamp_ns)

    def _log_skin(self, patch: str, raw: bytes, stamp_ns: int) -> None:
        from rclpy.serialization import deserialize_message
        from sensor_msgs.msg import PointCloud2

        m = self.fg.messages
        msg = deserialize_message(raw, PointCloud2)
        kinds = {7: m.PackedElementFieldNumericType.Float32}
        fields = [m.PackedElementField(name=f.name, offset=f.offset, type=kinds[f.datatype])
                  for f in msg.fields if f.datatype in kinds]
        self.skins[patch].log(m.PointCloud(
            timestamp=self._timestamp(stamp_ns), frame_id=msg.header.frame_id,
            pose=m.Pose(position=m.Vector3(), orientation=m.Quaternion(w=1.0)),
            point_stride=msg.point_step, fields=fields, data=bytes(msg.data),
        ), log_time=stamp_ns)

    def _log_contact(self, raw: bytes, stamp_ns: int) -> None:
        from rclpy.serialization import deserialize_message
        from sensor_msgs.msg import PointCloud2

        from phri_common.contact import ContactMessageError, msg_to_contact

        m = self.fg.messages
        try:
            c = msg_to_contact(deserialize_message(raw, PointCloud2))
        except ContactMessageError:
            return
        if not c.in_contact:
            self.contacts.log(m.SceneUpdate(deletions=[m.SceneEntityDeletion(
                timestamp=self._timestamp(stamp_ns), id=c.link)]), log_time=stamp_ns)
            return
        centre = np.asarray(c.center)
        force = np.asarray(c.force)
        length = 0.01 * float(np.linalg.norm(force))
        w, x, y, z = arrow_orientation(force)
        start = centre - force / max(float(np.linalg.norm(force)), 1e-9) * length
        red = m.Color(r=0.9, g=0.1, b=0.1, a=1.0)
        entity = m.SceneEntity(
            timestamp=self._timestamp(stamp_ns), frame_id=c.link, id=c.link, frame_locked=True,
            spheres=[m.SpherePrimitive(
                pose=m.Pose(position=m.Vector3(x=centre[0], y=centre[1], z=centre[2]),
                            orientation=m.Quaternion(w=1.0)),
                size=m.Vector3(x=0.03, y=0.03, z=0.03), color=m.Color(r=1.0, g=0.8, a=1.0))],
            arrows=[m.ArrowPrimitive(
                pose=m.Pose(position=m.Vector3(x=start[0], y=start[1], z=start[2]),
                            orientation=m.Quaternion(w=w, x=x, y=y, z=z)),
                shaft_length=max(length - 0.03, 0.005), shaft_diameter=0.01,
                head_length=0.03, head_diameter=0.025, color=red)],
        )
        self.contacts.log(m.SceneUpdate(entities=[entity]), log_time=stamp_ns)

    def _log_person(self, raw: bytes, stamp_ns: int) -> None:
        from geometry_msgs.msg import PoseArray
        from rclpy.serialization import deserialize_message

        m = self.fg.messages
        msg = deserialize_message(raw, PoseArray)
        sizes = (0.30, 0.10, 0.10)
        spheres = [
            m.SpherePrimitive(
                pose=m.Pose(position=m.Vector3(x=p.position.x, y=p.position.y, z=p.position.z),
                            orientation=m.Quaternion(w=1.0)),
                size=m.Vector3(x=s, y=s, z=s), color=m.Color(r=0.9, g=0.7, b=0.55, a=0.8))
            for p, s in zip(msg.poses, sizes, strict=False)
        ]
        self.person.log(m.SceneUpdate(entities=[m.SceneEntity(
            timestamp=self._timestamp(stamp_ns), frame_id="odom", id="person",
            spheres=spheres)]), log_time=stamp_ns)

    def _robot_scene(self) -> Any:
        """SceneUpdate with one frame-locked entity per link (phri_description geoms)."""
        from phri_description.description import robot_description

        m = self.fg.messages
        entities = []
        for link in robot_description().links:
            cubes, cylinders, spheres = [], [], []
            for g in link.geoms:
                w, x, y, z = _quat_from_matrix(g.rotation())
                pose = m.Pose(position=m.Vector3(x=g.pos[0], y=g.pos[1], z=g.pos[2]),
                              orientation=m.Quaternion(w=w, x=x, y=y, z=z))
                skin = link.name in SKIN_LINKS and g.shape == "cylinder"
                color = m.Color(r=g.rgba[0], g=g.rgba[1], b=g.rgba[2], a=g.rgba[3] if not skin
                                else 0.6)
                if g.shape == "box":
                    cubes.append(m.CubePrimitive(pose=pose, size=m.Vector3(
                        x=2 * g.size[0], y=2 * g.size[1], z=2 * g.size[2]), color=color))
                elif g.shape == "cylinder":
                    d = 2 * g.size[0]
                    cylinders.append(m.CylinderPrimitive(
                        pose=pose, size=m.Vector3(x=d, y=d, z=2 * g.size[1]), bottom_scale=1.0,
                        top_scale=1.0, color=color))
                else:
                    d = 2 * g.size[0]
                    spheres.append(m.SpherePrimitive(pose=pose, size=m.Vector3(x=d, y=d, z=d),
                                                     color=color))
            if cubes or cylinders or spheres:
                entities.append(m.SceneEntity(frame_id=link.name, id=link.name,
                                              frame_locked=True, cubes=cubes,
                                              cylinders=cylinders, spheres=spheres))
        return m.SceneUpdate(entities=entities)

    def close(self) -> None:
        """Stop the server (idempotent)."""
        if not self.closed:
            self.closed = True
            self.relay.close()
            self.server.stop()
