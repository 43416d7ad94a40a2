"""Serialized (CDR) bytes of the controller's small messages, read and written without rclpy.

rclpy turns every received message into Python objects and every published one back into C
structures; for the controller's five 500 Hz inputs and three 500 Hz commands that conversion
costs more than the arithmetic it carries (``bench/bench_controller.py --node-only``). A
subscription with ``raw=True`` hands over the serialized bytes, and ``Publisher.publish``
accepts bytes; these pure functions read and write them:

* :func:`joint_state_from_cdr`: ``sensor_msgs/JointState`` → (names, positions);
* :func:`joint_state_arrays_from_cdr`: the same with the velocities and efforts;
* :func:`odometry_pose_from_cdr`: ``nav_msgs/Odometry`` → (x, y, qx, qy, qz, qw) of the pose;
* :func:`odometry_from_cdr`: the same with the twist;
* :func:`stamped_xyz_from_cdr`: the point, force or vector of a ``PointStamped``,
  ``WrenchStamped`` or ``Vector3Stamped``;
* :func:`pose_array_from_cdr`: ``geometry_msgs/PoseArray`` → the poses;
* :func:`twist_from_cdr` / :func:`twist_to_cdr`: ``geometry_msgs/Twist`` ↔ its six numbers
  (the writer: (v_x, v_y, ω_z), the others 0);
* :func:`wrench_stamped_to_cdr`, :func:`point_stamped_to_cdr`, :func:`pose_array_to_cdr`: the
  simulator's ground truth, written;
* :class:`Float64ArrayEncoder`: a fixed layout of ``std_msgs/Float64MultiArray`` with fresh data.

Wire format (OMG XCDR1 as rmw_fastrtps writes it, the same as :mod:`phri_common.contact_cdr`):
a 4-byte encapsulation header (``00 01`` little endian, ``00 00`` big endian, two option
bytes), then the fields in order, each aligned to its own size (1, 4 or 8) counted from the end
of the encapsulation header; a string is a uint32 length that counts its terminating NUL, the
bytes and the NUL; a sequence is a uint32 count and the elements. Padding bytes may hold
anything. Only little-endian bytes are read: for big-endian ones the readers return ``None``
and the caller deserializes with rclpy (the reference path). Truncated or inconsistent bytes
raise :class:`CdrError` naming the field, the value and what was allowed.
"""

from __future__ import annotations

import struct
from collections.abc import Sequence

LITTLE_ENDIAN = b"\x00\x01"
"""Encapsulation identifier of little-endian plain CDR."""
_ENCAPSULATION = LITTLE_ENDIAN + b"\x00\x00"
_U32 = struct.Struct("<I")
_TWIST = struct.Struct("<6d")
_POSE = struct.Struct("<7d")  # position x, y, z; orientation x, y, z, w
_XYZ = struct.Struct("<3d")
_HEADER = struct.Struct("<iII")  # stamp.sec, stamp.nanosec, frame_id's length with its NUL
_NS_PER_S = 1_000_000_000  # phri_common.stamps.NS_PER_S, without its message import
MAX_STAMP_NS = 2**31 * _NS_PER_S
"""Stamps from 0 up to (not including) this [ns] fit ``header.stamp.sec`` (an int32)."""
MAX_NAMES = 4096
"""Most joint names a joint state may carry (a bound against garbage counts)."""


class CdrError(ValueError):
    """Serialized bytes that cannot be the message they were sent as."""


def _field_u32(data: bytes, offset: int, field: str) -> int:
    """The uint32 ``field`` at body ``offset`` (4-aligned)."""
    at = 4 + offset
    if len(data) < at + 4:
        raise CdrError(f"{field}: message ends at byte {len(data)}, the field needs "
                       f"bytes {at}..{at + 4}")
    value: int = _U32.unpack_from(data, at)[0]
    return value


def _align(offset: int, size: int) -> int:
    return offset + (-offset % size)


def _skip_header(data: bytes, field: str) -> int:
    """Body offset after a ``std_msgs/Header`` at body offset 0 (stamp, frame_id)."""
    return _skip_string(data, 8, f"{field}.header.frame_id")


def _skip_string(data: bytes, offset: int, field: str) -> int:
    """Body offset after the string ``field`` at (4-aligned) ``offset``."""
    length = _field_u32(data, offset, field)
    end = offset + 4 + length
    if length == 0 or len(data) < 4 + end:
        raise CdrError(f"{field}: string length {length} does not fit the {len(data)}-byte "
                       "message (allowed: 1 (the NUL) up to the bytes left)")
    return end


_last_names: list[tuple[bytes, tuple[str, ...]]] = [(b"", ())]
"""The last ``name`` block read and its strings: a publisher sends the same names every time."""


def _read_names(data: bytes, offset: int) -> tuple[tuple[str, ...], int]:
    """``name`` of a JointState at (4-aligned) body ``offset``: the strings and the offset
    after them. The same bytes as the last block (count, lengths, strings, padding) are the same
    names: they are reused instead of parsed again."""
    block, names = _last_names[0]
    if block and data[4 + offset : 4 + offset + len(block)] == block:
        return names, offset + len(block)
    names, end = _parse_names(data, offset)
    _last_names[0] = (data[4 + offset : 4 + end], names)
    return names, end


def _parse_names(data: bytes, offset: int) -> tuple[tuple[str, ...], int]:
    count = _field_u32(data, offset, "name (count)")
    if count > MAX_NAMES:
        raise CdrError(f"name: {count} names, allowed at most {MAX_NAMES}")
    names = []
    offset += 4
    for i in range(count):
        offset = _align(offset, 4)
        end = _skip_string(data, offset, f"name[{i}]")
        names.append(data[4 + offset + 4 : 4 + end - 1].decode("utf-8", errors="replace"))
        offset = end
    return tuple(names), offset


def _read_doubles(data: bytes, offset: int, field: str) -> tuple[tuple[float, ...], int]:
    """A ``float64[]`` at body ``offset``: the values and the offset after them."""
    count = _field_u32(data, _align(offset, 4), f"{field} (count)")
    start = _align(_align(offset, 4) + 4, 8) if count else _align(offset, 4) + 4
    end = start + 8 * count
    if len(data) < 4 + end:
        raise CdrError(f"{field}: {count} values do not fit the {len(data)}-byte message "
                       f"(allowed: at most {max(0, (len(data) - 4 - start) // 8)})")
    return struct.unpack_from(f"<{count}d", data, 4 + start), end


def joint_state_from_cdr(data: bytes) -> tuple[tuple[str, ...], tuple[float, ...]] | None:
    """``(name, position)`` of a serialized ``sensor_msgs/JointState``; ``None`` for big-endian
    bytes. Velocities and efforts are not read.

    Raises:
        CdrError: truncated or inconsistent bytes (names the field).
    """
    if data[:2] != LITTLE_ENDIAN:
        return None
    offset = _skip_header(data, "joint state")
    names, offset = _read_names(data, _align(offset, 4))
    positions, _ = _read_doubles(data, offset, "position")
    return names, positions


def joint_state_arrays_from_cdr(data: bytes) -> tuple[
        tuple[str, ...], tuple[float, ...], tuple[float, ...], tuple[float, ...]] | None:
    """``(name, position, velocity, effort)`` of a serialized ``sensor_msgs/JointState``
    [rad or m, rad/s or m/s, N·m or N; a field the sender left empty is empty]; ``None`` for
    big-endian bytes.

    Raises:
        CdrError: truncated or inconsistent bytes (names the field).
    """
    if data[:2] != LITTLE_ENDIAN:
        return None
    offset = _skip_header(data, "joint state")
    names, offset = _read_names(data, _align(offset, 4))
    positions, offset = _read_doubles(data, offset, "position")
    velocities, offset = _read_doubles(data, offset, "velocity")
    efforts, _ = _read_doubles(data, offset, "effort")
    return names, positions, velocities, efforts


def odometry_pose_from_cdr(data: bytes) -> tuple[float, ...] | None:
    """``(x, y, z, qx, qy, qz, qw)`` of ``pose.pose`` in a serialized ``nav_msgs/Odometry``
    [m, unit quaternion]; ``None`` for big-endian bytes.

    Raises:
        CdrError: truncated or inconsistent bytes (names the field).
    """
    if data[:2] != LITTLE_ENDIAN:
        return None
    offset = _skip_header(data, "odometry")
    offset = _align(_skip_string(data, _align(offset, 4), "odometry.child_frame_id"), 8)
    if len(data) < 4 + offset + _POSE.size:
        raise CdrError(f"odometry.pose.pose: message ends at byte {len(data)}, the pose needs "
                       f"bytes {4 + offset}..{4 + offset + _POSE.size}")
    values: tuple[float, ...] = _POSE.unpack_from(data, 4 + offset)
    return values


def _doubles_at(data: bytes, offset: int, count: int, field: str) -> tuple[float, ...]:
    """``count`` float64 at (8-aligned) body ``offset``."""
    if len(data) < 4 + offset + 8 * count:
        raise CdrError(f"{field}: message ends at byte {len(data)}, the field needs bytes "
                       f"{4 + offset}..{4 + offset + 8 * count}")
    return struct.unpack_from(f"<{count}d", data, 4 + offset)


def odometry_from_cdr(data: bytes) -> tuple[tuple[float, ...], tuple[float, ...]] | None:
    """``((x, y, z, qx, qy, qz, qw), (vx, vy, vz, wx, wy, wz))`` of ``pose.pose`` and
    ``twist.twist`` in a serialized ``nav_msgs/Odometry`` [m, unit quaternion, m/s, rad/s];
    ``None`` for big-endian bytes.

    Raises:
        CdrError: truncated or inconsistent bytes (names the field).
    """
    pose = odometry_pose_from_cdr(data)
    if pose is None:
        return None
    offset = _align(_skip_string(data, _align(_skip_header(data, "odometry"), 4),
                                 "odometry.child_frame_id"), 8)
    # pose (7), its covariance (36), then the twist
    return pose, _doubles_at(data, offset + 8 * 43, 6, "odometry.twist.twist")


def stamped_xyz_from_cdr(data: bytes, field: str) -> tuple[float, ...] | None:
    """The three float64 right after the header of a serialized stamped message:
    ``point`` of ``geometry_msgs/PointStamped``, ``wrench.force`` of ``WrenchStamped``,
    ``vector`` of ``Vector3Stamped`` (``field`` names it in errors); ``None`` for big-endian
    bytes.

    Raises:
        CdrError: truncated or inconsistent bytes (names the field).
    """
    if data[:2] != LITTLE_ENDIAN:
        return None
    return _doubles_at(data, _align(_skip_header(data, field), 8), 3, field)


def pose_array_from_cdr(data: bytes) -> list[tuple[float, ...]] | None:
    """``poses`` of a serialized ``geometry_msgs/PoseArray``, each ``(x, y, z, qx, qy, qz,
    qw)`` [m, unit quaternion]; ``None`` for big-endian bytes.

    Raises:
        CdrError: truncated or inconsistent bytes (names the field).
    """
    if data[:2] != LITTLE_ENDIAN:
        return None
    offset = _align(_skip_header(data, "pose array"), 4)
    count = _field_u32(data, offset, "poses (count)")
    if count == 0:  # no padding to the (absent) first pose
        return []
    start = _align(offset + 4, 8)
    if count > (len(data) - 4 - start) // _POSE.size:
        raise CdrError(f"poses: {count} poses do not fit the {len(data)}-byte message "
                       f"(allowed: at most {max(0, (len(data) - 4 - start) // _POSE.size)})")
    return [_POSE.unpack_from(data, 4 + start + _POSE.size * i) for i in range(count)]


def twist_from_cdr(data: bytes) -> tuple[float, ...] | None:
    """``(vx, vy, vz, wx, wy, wz)`` of a serialized ``geometry_msgs/Twist`` [m/s, rad/s];
    ``None`` for big-endian bytes.

    Raises:
        CdrError: truncated bytes.
    """
    if data[:2] != LITTLE_ENDIAN:
        return None
    return _doubles_at(data, 0, 6, "twist")


def twist_to_cdr(vx: float, vy: float, wz: float) -> bytes:
    """A serialized ``geometry_msgs/Twist`` with ``linear.x/y`` = ``vx``, ``vy`` [m/s],
    ``angular.z`` = ``wz`` [rad/s], the other three components 0."""
    return _ENCAPSULATION + _TWIST.pack(vx, vy, 0.0, 0.0, 0.0, wz)


def stamped_header_cdr(stamp_ns: int, frame_id: str, align: int) -> bytearray:
    """Little-endian encapsulation and ``std_msgs/Header`` (``stamp_ns`` [ns] as sec / nanosec,
    ``frame_id``), padded to the ``align``-byte alignment of the field that follows.

    Raises:
        ValueError: a stamp outside 0 ≤ stamp < 2³¹ s, or a frame id with a NUL inside.
    """
    if not 0 <= stamp_ns < MAX_STAMP_NS:
        raise ValueError(f"time stamp = {stamp_ns} ns: allowed 0 <= stamp < {MAX_STAMP_NS} ns "
                         "(header.stamp.sec is an int32)")
    if "\x00" in frame_id:
        raise ValueError(f"frame_id = {frame_id!r}: must not contain NUL")
    sec, nanosec = divmod(stamp_ns, _NS_PER_S)
    name = frame_id.encode() + b"\x00"
    head = bytearray(_ENCAPSULATION + _HEADER.pack(sec, nanosec, len(name)) + name)
    head += b"\x00" * (-(len(head) - 4) % align)
    return head


def wrench_stamped_to_cdr(stamp_ns: int, frame_id: str, force: Sequence[float],
                          torque: Sequence[float] = (0.0, 0.0, 0.0)) -> bytes:
    """A serialized ``geometry_msgs/WrenchStamped``: ``force`` [N] and ``torque`` [N·m] in
    ``frame_id`` at ``stamp_ns`` [ns] (ValueError as :func:`stamped_header_cdr`)."""
    return bytes(stamped_header_cdr(stamp_ns, frame_id, 8) + _TWIST.pack(*force, *torque))


def point_stamped_to_cdr(stamp_ns: int, frame_id: str, point: Sequence[float]) -> bytes:
    """A serialized ``geometry_msgs/PointStamped``: ``point`` [m] in ``frame_id`` at
    ``stamp_ns`` [ns] (ValueError as :func:`stamped_header_cdr`)."""
    return bytes(stamped_header_cdr(stamp_ns, frame_id, 8) + _XYZ.pack(*point))


def pose_array_to_cdr(stamp_ns: int, frame_id: str,
                      poses: Sequence[Sequence[float]]) -> bytes:
    """A serialized ``geometry_msgs/PoseArray`` in ``frame_id`` at ``stamp_ns`` [ns]; each pose
    ``(x, y, z, qx, qy, qz, qw)`` [m, unit quaternion], the order :func:`pose_array_from_cdr`
    returns (ValueError as :func:`stamped_header_cdr`)."""
    body = stamped_header_cdr(stamp_ns, frame_id, 4) + _U32.pack(len(poses))
    if poses:
        body += b"\x00" * (-(len(body) - 4) % 8)
    for pose in poses:
        body += _POSE.pack(*pose)
    return bytes(body)


class Float64ArrayEncoder:
    """Serialized ``std_msgs/Float64MultiArray`` with one ``dim`` (``label``, size = stride =
    ``size``), ``data_offset`` 0 and ``size`` values: the fixed part is built once.

    Raises:
        ValueError: ``size`` < 1 or a label that is not plain text (a NUL inside).
    """

    def __init__(self, label: str, size: int) -> None:
        if size < 1:
            raise ValueError(f"size = {size}: must be at least 1")
        if "\x00" in label:
            raise ValueError(f"label = {label!r}: must not contain NUL")
        name = label.encode() + b"\x00"
        body = bytearray(_U32.pack(1) + _U32.pack(len(name)) + name)  # dim: one entry
        body += b"\x00" * (-len(body) % 4)
        body += struct.pack("<IIII", size, size, 0, size)  # size, stride, data_offset, count
        body += b"\x00" * (-len(body) % 8)
        self.size = size
        self._prefix = _ENCAPSULATION + bytes(body)
        self._values = struct.Struct(f"<{size}d")

    def encode(self, values: Sequence[float]) -> bytes:
        """The message with ``data`` = ``values`` (exactly ``size`` numbers).

        Raises:
            ValueError: a different number of values.
        """
        if len(values) != self.size:
            raise ValueError(f"values: {len(values)} numbers, expected {self.size}")
        return self._prefix + self._values.pack(*values)


__all__ = ["LITTLE_ENDIAN", "MAX_NAMES", "CdrError", "Float64ArrayEncoder",
           "joint_state_arrays_from_cdr", "joint_state_from_cdr", "odometry_pose_from_cdr",
           "point_stamped_to_cdr", "pose_array_to_cdr", "stamped_header_cdr", "twist_to_cdr",
           "wrench_stamped_to_cdr"]
