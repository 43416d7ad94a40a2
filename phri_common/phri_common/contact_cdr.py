"""Contact states straight from their serialized (CDR) bytes: the controller's cheap input path.

rclpy turns every received PointCloud2 into Python objects, one ``PointField`` per field: for a
contact state (17 fields, 125 bytes of data) that costs several times the decoding itself,
1,500 times a second in the controller (docs/benchmarks.md, "Controller node"). A subscription
with ``raw=True`` hands over the bytes instead;
:func:`contact_from_cdr` reads phri's own layout (:func:`phri_common.contact.contact_to_msg`)
from them directly and returns ``None`` for anything else, which the caller then deserializes
and decodes with :func:`phri_common.contact.msg_to_contact`, the reference: same state, same
refusals.

Wire format (OMG XCDR1, little endian, as rmw_fastrtps writes it): a 4-byte encapsulation
header ``00 01 00 00``, then ``header.stamp`` (int32 sec, uint32 nanosec), ``header.frame_id``
(uint32 length including the NUL, the bytes, the NUL), padding to 4, then height, width, the
fields, is_bigendian, point_step, row_step and the data length, which for phri's layout are one
fixed byte sequence (:data:`TEMPLATE`) except for padding bytes, whose value is unspecified
(:data:`MASK` leaves them out), then the 125 data bytes and is_dense.
:func:`contact_to_cdr` writes the same bytes (padding zero) for a publisher's ``publish(bytes)``:
the estimator's side of the same saving.
"""

from __future__ import annotations

import struct

from sensor_msgs.msg import PointField

from phri_common.cdr import _HEADER, MAX_STAMP_NS, stamped_header_cdr  # noqa: F401 (re-exported)
from phri_common.contact import _FIELDS, _STRUCT, contact_data, contact_from_values
from phri_common.records import ContactState
from phri_common.stamps import NS_PER_S

_CDR_LE = b"\x00\x01"
"""Encapsulation of plain little-endian CDR."""


def layout_template(fields: tuple[PointField, ...] | list[PointField],
                    point_size: int, width: int = 1) -> tuple[bytes, bytes]:
    """CDR bytes of a one-row cloud's fixed part (height … data length) and their mask
    (0x00 at padding bytes, 0xff elsewhere), starting at a 4-aligned offset."""
    out, mask = bytearray(), bytearray()

    def put(data: bytes, meaningful: bool = True) -> None:
        out.extend(data)
        mask.extend((b"\xff" if meaningful else b"\x00") * len(data))

    def align4() -> None:
        put(b"\x00" * (-len(out) % 4), meaningful=False)

    put(struct.pack("<III", 1, width, len(fields)))  # height, width, field count
    for f in fields:
        name = f.name.encode() + b"\x00"
        put(struct.pack("<I", len(name)) + name)
        align4()
        put(struct.pack("<IB", f.offset, f.datatype))
        align4()
        put(struct.pack("<I", f.count))
    put(b"\x00")  # is_bigendian
    align4()
    row = point_size * width
    put(struct.pack("<III", point_size, row, row))  # point step, row step, data length
    return bytes(out), bytes(mask)


class Template:
    """A fixed byte sequence with don't-care (padding) bytes, compared as masked integers: one
    ``int.from_bytes`` and an ``&``, far below numpy's per-call overhead."""

    __slots__ = ("mask", "size", "value")

    def __init__(self, fixed: bytes, mask: bytes) -> None:
        if len(fixed) != len(mask):
            raise ValueError(f"template of {len(fixed)} bytes, mask of {len(mask)}: must match")
        self.size = len(fixed)
        self.mask = int.from_bytes(mask, "little")
        self.value = int.from_bytes(fixed, "little") & self.mask


TEMPLATE, MASK = layout_template(_FIELDS, _STRUCT.size)
_CONTACT_TEMPLATE = Template(TEMPLATE, MASK)
"""First time stamp a message header cannot hold (its ``sec`` is an int32) [ns]."""


def cloud_header(data: bytes) -> tuple[str, int, int] | None:
    """``(frame_id, stamp [ns], offset of height)`` of a serialized little-endian
    PointCloud2, or ``None`` if it is not one (or too short to tell)."""
    if data[:2] != _CDR_LE or len(data) < 16:
        return None
    sec, nanosec, length = _HEADER.unpack_from(data, 4)
    start = 16 + length  # body offset 12 + length, body starting after the 4-byte header
    if length == 0 or len(data) < start or data[start - 1] != 0:
        return None
    frame_id = data[16 : 16 + length - 1].decode("utf-8", errors="replace")
    return frame_id, sec * NS_PER_S + nanosec, start + (-(start - 4) % 4)


def matches(data: bytes, start: int, template: Template) -> bool:
    """Whether ``data`` holds ``template`` at ``start``, padding aside."""
    end = start + template.size
    if len(data) < end:
        return False
    return int.from_bytes(data[start:end], "little") & template.mask == template.value


def contact_from_cdr(data: bytes) -> ContactState | None:
    """The contact state in a serialized PointCloud2 of phri's own layout, else ``None``.

    Raises:
        ContactMessageError: phri's layout holding non-finite values (as msg_to_contact).
    """
    header = cloud_header(data)
    if header is None:
        return None
    frame_id, stamp_ns, start = header
    end = start + len(TEMPLATE)
    if len(data) < end + _STRUCT.size or not matches(data, start, _CONTACT_TEMPLATE):
        return None
    return contact_from_values(frame_id, stamp_ns, _STRUCT.unpack_from(data, end))


def contact_to_cdr(state: ContactState) -> bytes:
    """The serialized PointCloud2 of :func:`phri_common.contact.contact_to_msg`, ready for
    ``Publisher.publish``.

    Raises:
        ValueError: ``stamp_ns`` outside 0 ≤ stamp < :data:`MAX_STAMP_NS`.
    """
    head = stamped_header_cdr(state.stamp_ns, state.link, 4)
    return bytes(head) + TEMPLATE + contact_data(state) + b"\x01"  # is_dense
