"""rosbag2 recordings in MCAP, written by rosbags' rosbag2 writer (pure: no rclpy).

A recording is a rosbag2 bag directory (format version 9, storage ``mcap``): ``<name>.mcap``
(profile ``ros2``, schemas as ROS 2 ``.msg`` text, messages as the CDR bytes exactly as they
travelled, zstd-compressed chunks) and ``metadata.yaml`` with each topic's type, type hash
(RIHS01) and offered QoS profiles (:data:`TOPIC_QOS`), so ``ros2 bag info`` / ``ros2 bag play``
(latched topics replayed latched), rosbags, Foxglove and Lichtblick open it. rosbags (a
maintained implementation of the rosbag2 format) writes the file, the channels' QoS metadata and
``metadata.yaml``; this module only chooses what goes in.

Message definitions and type hashes come from rosbags' type store (the ROS 2 Kilted
definitions); messages the recorder computes itself (``/tf``, ``/tf_static``,
``/robot_description``) are encoded with mcap-ros2-support's dynamic serializer.
"""

from __future__ import annotations

import shutil
import struct
from collections.abc import Callable
from dataclasses import dataclass
from functools import cache
from pathlib import Path
from typing import Any

from rosbags.interfaces import (
    Connection,
    Qos,
    QosDurability,
    QosHistory,
    QosLiveliness,
    QosReliability,
    QosTime,
)
from rosbags.rosbag2 import CompressionFormat, CompressionMode, StoragePlugin, Writer

from phri_bringup.observer.link_frames import Transform

HEADER_FIRST_TYPES = frozenset({
    "sensor_msgs/msg/PointCloud2", "sensor_msgs/msg/JointState", "nav_msgs/msg/Odometry",
    "geometry_msgs/msg/WrenchStamped", "geometry_msgs/msg/PointStamped",
    "geometry_msgs/msg/PoseArray", "diagnostic_msgs/msg/DiagnosticArray",
    "rosgraph_msgs/msg/Clock",
})
"""Types whose CDR starts with a time (std_msgs/Header.stamp or Clock.clock)."""

_STAMP = struct.Struct("<iI")


def stamp_ns_of(type_name: str, raw: bytes) -> int | None:
    """Header stamp [ns] read straight from a CDR message (4-byte encapsulation, then int32 sec,
    uint32 nanosec), or None for types without a leading stamp or a too-short message."""
    if type_name not in HEADER_FIRST_TYPES or len(raw) < 12 or raw[1] != 1:
        return None
    sec, nanosec = _STAMP.unpack_from(raw, 4)
    return int(sec) * 1_000_000_000 + int(nanosec)


@cache
def typestore() -> Any:
    """rosbags' type store of ROS 2 Kilted (message definitions and RIHS01 type hashes)."""
    from rosbags.typesys import Stores, get_typestore

    return get_typestore(Stores.ROS2_KILTED)


@cache
def message_definition(type_name: str) -> str:
    """ROS 2 message definition text (with dependencies) of ``pkg/msg/Type``."""
    return str(typestore().generate_msgdef(type_name, ros_version=2)[0])


@cache
def ros_type(type_name: str) -> Any:
    """``pkg/msg/Type`` → the rclpy message class (for fast CDR deserialisation of records that
    rosbags read; rosbags' own deserialiser is ~40× slower per message)."""
    import importlib

    package, _, name = type_name.split("/")
    return getattr(importlib.import_module(f"{package}.msg"), name)


@cache
def _encoder(type_name: str) -> Callable[[Any], bytes]:
    from mcap_ros2._dynamic import serialize_dynamic

    encoders = serialize_dynamic(type_name, message_definition(type_name))
    fn = encoders[type_name]
    return lambda msg: bytes(fn(msg))


def tf_message(transforms: list[Transform], stamp_ns: int) -> dict[str, Any]:
    """A tf2_msgs/TFMessage as a plain dict for the dynamic encoder."""
    stamp = {"sec": stamp_ns // 1_000_000_000, "nanosec": stamp_ns % 1_000_000_000}
    return {"transforms": [
        {
            "header": {"stamp": stamp, "frame_id": t.parent},
            "child_frame_id": t.child,
            "transform": {
                "translation": dict(zip("xyz", t.translation, strict=True)),
                "rotation": dict(zip("wxyz", t.rotation, strict=True)),
            },
        }
        for t in transforms
    ]}


def encode(type_name: str, message: dict[str, Any]) -> bytes:
    """CDR bytes of a message given as a dict (mcap-ros2-support's dynamic encoder)."""
    return _encoder(type_name)(message)


@dataclass(frozen=True)
class TopicQos:
    """The QoS a topic's publishers offer, as rosbag2 stores it (``offered_qos_profiles``).

    Attributes:
        depth: history depth (keep last).
        reliable: reliable (else best effort).
        latched: durability transient local (a late subscriber gets the last message): what
            ``ros2 bag play`` needs to replay ``/robot_description`` and ``/tf_static`` latched.
    """

    depth: int = 10
    reliable: bool = True
    latched: bool = False

    def profile(self) -> Qos:
        """The rosbags QoS record (deadline, lifespan, lease: the ROS defaults, 0 = unset)."""
        zero = QosTime(sec=0, nsec=0)
        return Qos(
            history=QosHistory.KEEP_LAST, depth=self.depth,
            reliability=QosReliability.RELIABLE if self.reliable else QosReliability.BEST_EFFORT,
            durability=QosDurability.TRANSIENT_LOCAL if self.latched else QosDurability.VOLATILE,
            deadline=zero, lifespan=zero, liveliness=QosLiveliness.AUTOMATIC,
            liveliness_lease_duration=zero, avoid_ros_namespace_conventions=False,
        )


DEFAULT_QOS = TopicQos()
"""What phri's nodes offer on every topic they publish (reliable, volatile, keep last 10:
phri_sim's bridge, contact_estimation's states, the controller's commands; docs/interfaces.md)."""
LATCHED_QOS = TopicQos(depth=1, latched=True)
"""robot_state_publisher's ``/robot_description`` and tf2's static broadcaster's ``/tf_static``
(reliable, transient local, depth 1)."""
TOPIC_QOS: dict[str, TopicQos] = {
    "/tf": TopicQos(depth=100),  # tf2_ros.TransformBroadcaster's profile
    "/tf_static": LATCHED_QOS,
    "/robot_description": LATCHED_QOS,
}
"""Topics whose publishers offer something else than :data:`DEFAULT_QOS`."""


def topic_qos(topic: str) -> TopicQos:
    """The offered QoS recorded for ``topic``."""
    return TOPIC_QOS.get(topic, DEFAULT_QOS)


def clear_previous_recording(directory: Path) -> None:
    """Remove an earlier recording in ``directory`` (a re-run with the same ``--out``).

    Raises:
        ValueError: ``directory`` exists but is not a recording (holds anything but
            ``metadata.yaml`` and ``*.mcap`` files): nothing is deleted.
    """
    if not directory.exists():
        return
    if not directory.is_dir():
        raise ValueError(f"recording directory {directory} is a file")
    others = [p.name for p in directory.iterdir()
              if not (p.is_file() and (p.name == "metadata.yaml" or p.suffix == ".mcap"))]
    if others:
        raise ValueError(f"recording directory {directory} holds other files "
                         f"({', '.join(sorted(others)[:3])}): choose an empty or new directory")
    shutil.rmtree(directory)


class McapRecording:
    """Writes one rosbag2 MCAP bag directory through rosbags' :class:`Writer`.

    Args:
        directory: the bag directory (created; an earlier recording there is replaced, see
            :func:`clear_previous_recording`).
    """

    def __init__(self, directory: str | Path) -> None:
        self.directory = Path(directory)
        clear_previous_recording(self.directory)
        self.directory.parent.mkdir(parents=True, exist_ok=True)
        self._writer = Writer(self.directory, version=Writer.VERSION_LATEST,
                              storage_plugin=StoragePlugin.MCAP)
        self._writer.set_compression(CompressionMode.STORAGE, CompressionFormat.ZSTD)
        self._writer.open()
        self.path = self.directory / f"{self.directory.name}.mcap"
        """The MCAP file (rosbags names it after the directory)."""
        self._channels: dict[str, tuple[Connection, str]] = {}
        self.counts: dict[str, int] = {}
        self.first_ns: int | None = None
        self.last_ns = 0
        self.closed = False

    def _channel(self, topic: str, type_name: str) -> Connection:
        known = self._channels.get(topic)
        if known is not None:
            if known[1] != type_name:
                raise ValueError(f"topic {topic} recorded as {known[1]}, got {type_name}")
            return known[0]
        connection = self._writer.add_connection(
            topic, type_name, typestore=typestore(), serialization_format="cdr",
            offered_qos_profiles=[topic_qos(topic).profile()])
        self._channels[topic] = (connection, type_name)
        self.counts[topic] = 0
        return connection

    def declare(self, topic: str, type_name: str) -> None:
        """Register ``topic`` now, so it is listed even if no message arrives (e.g. a contact
        centre of a link never touched)."""
        self._channel(topic, type_name)

    def add(self, topic: str, type_name: str, raw: bytes, log_time_ns: int) -> None:
        """Record one CDR message on ``topic`` at ``log_time_ns`` [ns]."""
        if self.closed:
            return
        connection = self._channel(topic, type_name)
        self._writer.write(connection, log_time_ns, raw)
        self.counts[topic] += 1
        self.first_ns = log_time_ns if self.first_ns is None else min(self.first_ns, log_time_ns)
        self.last_ns = max(self.last_ns, log_time_ns)

    def close(self) -> None:
        """Finish the MCAP file and write ``metadata.yaml`` (idempotent)."""
        if self.closed:
            return
        self.closed = True
        self._writer.close()


def find_recording(path: str | Path) -> Path:
    """The recording directory (with metadata.yaml) or MCAP file under ``path``: a run
    directory, a recording directory or an ``.mcap`` file.

    Raises:
        FileNotFoundError: nothing recorded there.
    """
    p = Path(path)
    if p.is_file() and p.suffix == ".mcap":
        return p
    if (p / "metadata.yaml").is_file():
        return p
    for candidate in sorted(p.glob("*/metadata.yaml")):
        return candidate.parent
    for mcap in sorted(p.rglob("*.mcap")):
        return mcap
    raise FileNotFoundError(f"no MCAP recording in {p}")
