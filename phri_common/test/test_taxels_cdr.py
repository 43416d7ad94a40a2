"""taxels_from_cdr (serialized bytes → TaxelArray) against the reference decoder.

The reference is rclpy's deserialization followed by msg_to_taxels. For phri's own layouts
(TaxelCloudEncoder, with and without weights) both must give the same taxel array, whatever the
frame id's length (it shifts the alignment of what follows) and the taxel count; any other
layout must be declined (None) and left to the reference.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from rclpy.serialization import deserialize_message, serialize_message
from sensor_msgs.msg import PointCloud2, PointField

from phri_common.taxels import TaxelCloudEncoder, msg_to_taxels
from phri_common.taxels_cdr import taxels_from_cdr


@settings(max_examples=80, deadline=None, derandomize=True)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(1, 400), weighted=st.booleans(),
       frame_id=st.text(st.characters(min_codepoint=33, max_codepoint=0x2FF), min_size=1,
                        max_size=21),
       stamp=st.integers(0, 2**62))
def test_phri_layouts_decode_exactly_as_the_reference(seed: int, n: int, weighted: bool,
                                                      frame_id: str, stamp: int) -> None:
    rng = np.random.default_rng(seed)
    weights = rng.uniform(0.0, 2.0, n) if weighted else None
    encoder = TaxelCloudEncoder(rng.normal(size=(n, 3)), rng.normal(size=(n, 3)), frame_id,
                                weights)
    data = serialize_message(encoder.encode(rng.uniform(-1.0, 30.0, n), stamp))
    fast = taxels_from_cdr(data)
    reference = msg_to_taxels(deserialize_message(data, PointCloud2))
    assert fast is not None
    assert fast == reference
    assert fast.frame_id == frame_id and fast.stamp_ns == stamp


def _other_layouts() -> list[PointCloud2]:
    rng = np.random.default_rng(1)
    msgs = []
    for change in ("float64", "missing", "extra", "bigendian", "rows"):
        msg = TaxelCloudEncoder(rng.normal(size=(6, 3)), rng.normal(size=(6, 3)), "l").encode(
            np.ones(6), 5)
        if change == "float64":
            fields = list(msg.fields)
            fields[6] = PointField(name="force", offset=24, datatype=PointField.FLOAT64,
                                   count=1)
            msg.fields = fields
        elif change == "missing":
            msg.fields = list(msg.fields)[:6]
        elif change == "extra":
            msg.fields = [*msg.fields, PointField(name="id", offset=28,
                                                  datatype=PointField.UINT32, count=1)]
            msg.point_step, msg.row_step = 32, 32 * 6
            msg.data = bytes(msg.data) + bytes(24)
        elif change == "bigendian":
            msg.is_bigendian = True
        else:
            msg.height, msg.width, msg.row_step = 2, 3, 28 * 3
        msgs.append(msg)
    return msgs


@pytest.mark.parametrize("msg", _other_layouts())
def test_any_other_layout_is_declined(msg: PointCloud2) -> None:
    assert taxels_from_cdr(serialize_message(msg)) is None


def test_truncated_or_foreign_bytes_are_declined() -> None:
    data = serialize_message(TaxelCloudEncoder(np.zeros((4, 3)), np.ones((4, 3)), "l").encode(
        np.ones(4), 1))
    assert taxels_from_cdr(data[:-20]) is None
    assert taxels_from_cdr(b"\x00\x00" + data[2:]) is None
    assert taxels_from_cdr(b"") is None
