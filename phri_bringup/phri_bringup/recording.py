"""MCAP recordings in ROS 2 CDR, without rosbag2 (pure: no rclpy).

A recording is a rosbag2-style directory: ``<name>_0.mcap`` (profile ``ros2``, schemas as ROS 2
``.msg`` text, messages as the CDR bytes exactly as they travelled, zstd-compressed chunks) and a
``metadata.yaml``, so ``ros2 bag info/play DIR``, rosbags, Foxglove and Lichtblick open it.

Message definitions come from rosbags' type store (the ROS 2 Kilted definitions); messages the
recorder computes itself (``/tf``) are encoded with mcap-ros2-support's dynamic serializer.
"""

from __future__ import annotations

import struct
from collections.abc import Callable
from functools import cache
from pathlib import Path
from typing import Any, BinaryIO

import yaml
from mcap.well_known import MessageEncoding, SchemaEncoding
from mcap.writer import CompressionType, Writer

from phri_bringup.frames import Transform

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
def message_definition(type_name: str) -> str:
    """ROS 2 message definition text (with dependencies) of ``pkg/msg/Type``."""
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_KILTED)
    return str(store.generate_msgdef(type_name, ros_version=2)[0])


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


class McapRecording:
    """Writes one rosbag2-compatible MCAP recording directory."""

    def __init__(self, directory: str | Path, name: str = "recording") -> None:
        self.directory = Path(directory)
        self.directory.mkdir(parents=True, exist_ok=True)
        self.path = self.directory / f"{name}_0.mcap"
        self._stream: BinaryIO = self.path.open("wb")
        self._writer = Writer(self._stream, compression=CompressionType.ZSTD,
                              chunk_size=4 * 1024 * 1024)
        self._writer.start(profile="ros2", library="phri_bringup")
        self._schemas: dict[str, int] = {}
        self._channels: dict[str, tuple[int, str]] = {}
        self.counts: dict[str, int] = {}
        self.first_ns: int | None = None
        self.last_ns = 0
        self.closed = False

    def _channel(self, topic: str, type_name: str) -> int:
        known = self._channels.get(topic)
        if known is not None:
            if known[1] != type_name:
                raise ValueError(f"topic {topic} recorded as {known[1]}, got {type_name}")
            return known[0]
        schema = self._schemas.get(type_name)
        if schema is None:
            schema = self._writer.register_schema(
                type_name, SchemaEncoding.ROS2, message_definition(type_name).encode()
            )
            self._schemas[type_name] = schema
        channel = self._writer.register_channel(topic, MessageEncoding.CDR, schema)
        self._channels[topic] = (channel, type_name)
        self.counts[topic] = 0
        return channel

    def declare(self, topic: str, type_name: str) -> None:
        """Register ``topic`` now, so it is listed even if no message arrives (e.g. a contact
        centre of a link never touched)."""
        self._channel(topic, type_name)

    def add(self, topic: str, type_name: str, raw: bytes, log_time_ns: int) -> None:
        """Record one CDR message on ``topic`` at ``log_time_ns`` [ns]."""
        if self.closed:
            return
        channel = self._channel(topic, type_name)
        self._writer.add_message(channel, log_time=log_time_ns, data=raw,
                                 publish_time=log_time_ns, sequence=self.counts[topic])
        self.counts[topic] += 1
        self.first_ns = log_time_ns if self.first_ns is None else min(self.first_ns, log_time_ns)
        self.last_ns = max(self.last_ns, log_time_ns)

    def close(self) -> None:
        """Finish the MCAP file and write ``metadata.yaml``."""
        if self.closed:
            return
        self.closed = True
        self._writer.finish()
        self._stream.close()
        (self.directory / "metadata.yaml").write_text(self.metadata_yaml(), encoding="utf-8")

    def metadata_yaml(self) -> str:
        """rosbag2 ``metadata.yaml`` (version 5) describing the MCAP file."""
        start = self.first_ns or 0
        duration = max(0, self.last_ns - start)
        total = sum(self.counts.values())
        info = {
            "version": 5,
            "storage_identifier": "mcap",
            "duration": {"nanoseconds": duration},
            "starting_time": {"nanoseconds_since_epoch": start},
            "message_count": total,
            "topics_with_message_count": [
                {"topic_metadata": {"name": topic, "type": type_name,
                                    "serialization_format": "cdr",
                                    "offered_qos_profiles": ""},
                 "message_count": self.counts[topic]}
                for topic, (_, type_name) in self._channels.items()
            ],
            "compression_format": "",
            "compression_mode": "",
            "relative_file_paths": [self.path.name],
            "files": [{"path": self.path.name,
                       "starting_time": {"nanoseconds_since_epoch": start},
                       "duration": {"nanoseconds": duration},
                       "message_count": total}],
            "custom_data": {},
        }
        return str(yaml.safe_dump({"rosbag2_bagfile_information": info}, sort_keys=False))


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
