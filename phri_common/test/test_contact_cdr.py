"""contact_from_cdr (serialized bytes → ContactState) against the reference decoder.

The reference is rclpy's deserialization followed by msg_to_contact. For phri's own layout both
must give the same state (every field, bit for bit) whatever the link name's length (it shifts
the alignment of everything after it); for any other layout contact_from_cdr must decline
(None), never guess; non-finite values are refused the same way.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from rclpy.serialization import deserialize_message, serialize_message
from sensor_msgs.msg import PointCloud2, PointField

from phri_common.contact import ContactMessageError, contact_to_msg, msg_to_contact
from phri_common.contact_cdr import MAX_STAMP_NS, contact_from_cdr, contact_to_cdr
from phri_common.records import ContactState

finite = st.floats(-1e6, 1e6, allow_nan=False)
vector = st.tuples(finite, finite, finite)


@settings(max_examples=150, deadline=None, derandomize=True)
@given(link=st.text(st.characters(min_codepoint=33, max_codepoint=0x2FF), min_size=1,
                    max_size=23),
       stamp=st.integers(0, MAX_STAMP_NS - 1), touched=st.booleans(),
       count=st.integers(0, 2**32 - 1),
       vectors=st.tuples(vector, vector, vector, vector, vector))
def test_phri_layout_decodes_exactly_as_the_reference(link: str, stamp: int, touched: bool,
                                                      count: int, vectors: tuple) -> None:
    state = ContactState(link, stamp, touched, *vectors, taxel_count=count) if touched \
        else ContactState.no_contact(link, stamp)
    data = serialize_message(contact_to_msg(state))
    fast = contact_from_cdr(data)
    reference = msg_to_contact(deserialize_message(data, PointCloud2))
    assert fast is not None
    assert fast == reference == state


def _other_layouts() -> list[PointCloud2]:
    state = ContactState("left_forearm_link", 5, True, [1.0, 2.0, 3.0], [0.0, 0.0, -5.0],
                         [0.0, 0.1, 0.0], [0.9, 1.9, 2.9], [1.1, 2.1, 3.1], 7)
    msgs = []
    for change in ("width", "bigendian", "field", "step", "extra"):
        msg = contact_to_msg(state)
        if change == "width":
            msg.width, msg.height = 1, 1
            msg.data = bytes(msg.data) * 2
            msg.width = 2
        elif change == "bigendian":
            msg.is_bigendian = True
        elif change == "field":
            fields = list(msg.fields)
            fields[3] = PointField(name="force_y", offset=24, datatype=PointField.FLOAT64,
                                   count=1)
            msg.fields = fields
        elif change == "step":
            msg.point_step = 128
            msg.row_step = 128
            msg.data = bytes(msg.data) + b"\x00\x00\x00"
        else:
            msg.fields = [*msg.fields, PointField(name="extra", offset=125,
                                                  datatype=PointField.UINT8, count=1)]
        msgs.append(msg)
    return msgs


@pytest.mark.parametrize("msg", _other_layouts())
def test_any_other_layout_is_declined(msg: PointCloud2) -> None:
    assert contact_from_cdr(serialize_message(msg)) is None


@pytest.mark.parametrize("bad", [math.nan, math.inf])
def test_non_finite_values_are_refused_like_the_reference(bad: float) -> None:
    msg = contact_to_msg(ContactState("l", 1, True, [0.0, 0.0, 0.0], [1.0, 0.0, 0.0]))
    raw = bytearray(msg.data)
    raw[24:32] = np.float64(bad).tobytes()  # force_x
    msg.data = bytes(raw)
    data = serialize_message(msg)
    with pytest.raises(ContactMessageError, match="non-finite force") as reference:
        msg_to_contact(deserialize_message(data, PointCloud2))
    with pytest.raises(ContactMessageError) as fast:
        contact_from_cdr(data)
    assert str(fast.value) == str(reference.value)


def test_not_cdr_little_endian_is_declined() -> None:
    data = bytearray(serialize_message(contact_to_msg(ContactState.no_contact("l", 0))))
    data[1] = 0  # big-endian CDR encapsulation
    assert contact_from_cdr(bytes(data)) is None
    assert contact_from_cdr(b"") is None


def test_a_stamp_beyond_the_headers_int32_seconds_is_refused_naming_the_range() -> None:
    # 2**31 s: header.stamp.sec is an int32 (rclpy's Time refuses it too).
    with pytest.raises(ValueError, match=r"time stamp = 2147483648000000000 ns: allowed 0 <="):
        contact_to_cdr(ContactState.no_contact("l", 2**31 * 10**9))
    with pytest.raises(ValueError, match=r"time stamp = -1 ns"):
        contact_to_cdr(ContactState.no_contact("l", -1))
    contact_to_cdr(ContactState.no_contact("l", 2**31 * 10**9 - 1))  # the last one that fits


@settings(max_examples=100, deadline=None, derandomize=True)
@given(link=st.text(st.characters(min_codepoint=33, max_codepoint=0x2FF), min_size=1,
                    max_size=23),
       stamp=st.integers(0, MAX_STAMP_NS - 1), touched=st.booleans(),
       count=st.integers(0, 2**32 - 1),
       vectors=st.tuples(vector, vector, vector, vector, vector))
def test_encoder_writes_what_rclpy_reads_as_contact_to_msg(link: str, stamp: int,
                                                            touched: bool, count: int,
                                                            vectors: tuple) -> None:
    state = ContactState(link, stamp, touched, *vectors, taxel_count=count) if touched \
        else ContactState.no_contact(link, stamp)
    msg = deserialize_message(contact_to_cdr(state), PointCloud2)
    reference = contact_to_msg(state)
    assert msg == reference  # every field of the message, header and layout included
    assert msg_to_contact(msg) == state
