"""Round trips and malformed input for the taxel-array and contact-state messages."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from sensor_msgs.msg import PointCloud2, PointField

from phri_common.contact import ContactMessageError, contact_to_msg, msg_to_contact
from phri_common.records import ContactState, TaxelArray
from phri_common.taxels import (
    TaxelCloudEncoder,
    TaxelMessageError,
    msg_to_taxels,
    taxels_to_msg,
)

finite = st.floats(-10.0, 10.0, allow_nan=False, width=32)


@settings(max_examples=50, deadline=None)
@given(n=st.integers(0, 50), data=st.data(), weighted=st.booleans())
def test_taxel_round_trip_preserves_every_value(
    n: int, data: st.DataObject, weighted: bool
) -> None:
    positions = data.draw(arrays(np.float32, (n, 3), elements=finite))
    normals = data.draw(arrays(np.float32, (n, 3), elements=finite))
    forces = data.draw(arrays(np.float32, (n,), elements=finite))
    weights = data.draw(arrays(np.float32, (n,), elements=finite)) if weighted else None
    taxels = TaxelArray(positions, normals, forces, weights, "left_forearm_link", 1_234_567_890_123)
    decoded = msg_to_taxels(taxels_to_msg(taxels))
    np.testing.assert_array_equal(decoded.positions, positions)
    np.testing.assert_array_equal(decoded.normals, normals)
    np.testing.assert_array_equal(decoded.forces, forces)
    if weighted:
        assert decoded.weights is not None
        np.testing.assert_array_equal(decoded.weights, weights)
    else:
        assert decoded.weights is None
    assert decoded.frame_id == "left_forearm_link"
    assert decoded.stamp_ns == 1_234_567_890_123


def test_encoder_reuses_geometry_and_only_changes_forces() -> None:
    rng = np.random.default_rng(0)
    pos, nrm = rng.normal(size=(20, 3)), rng.normal(size=(20, 3))
    enc = TaxelCloudEncoder(pos, nrm, "link")
    a = msg_to_taxels(enc.encode(np.full(20, 1.0), 10))
    b = msg_to_taxels(enc.encode(np.arange(20.0), 20))
    np.testing.assert_allclose(a.positions, b.positions)
    np.testing.assert_allclose(b.forces, np.arange(20.0))
    np.testing.assert_allclose(a.forces, 1.0)
    assert (a.stamp_ns, b.stamp_ns) == (10, 20)


def test_encoder_refuses_forces_of_the_wrong_size() -> None:
    enc = TaxelCloudEncoder(np.zeros((4, 3)), np.zeros((4, 3)), "link")
    with pytest.raises(ValueError, match=r"shape \(4,\)"):
        enc.encode(np.zeros(5), 0)


def test_mismatched_geometry_is_refused() -> None:
    with pytest.raises(ValueError, match="normals"):
        TaxelCloudEncoder(np.zeros((4, 3)), np.zeros((3, 3)), "link")


def test_truncated_taxel_data_is_a_clear_error() -> None:
    msg = taxels_to_msg(TaxelArray(np.zeros((4, 3)), np.zeros((4, 3)), np.ones(4), None, "l", 0))
    msg.data = bytes(msg.data)[:-3]
    with pytest.raises(TaxelMessageError, match="bytes"):
        msg_to_taxels(msg)


def test_cloud_without_force_field_is_refused() -> None:
    msg = PointCloud2(
        height=1, width=0, point_step=12, row_step=0,
        fields=[PointField(name=a, offset=4 * i, datatype=PointField.FLOAT32, count=1)
                for i, a in enumerate("xyz")],
    )
    with pytest.raises(TaxelMessageError, match=r"normal_x.*force"):
        msg_to_taxels(msg)


def test_float64_taxel_cloud_from_another_publisher_is_decoded() -> None:
    names = ["x", "y", "z", "normal_x", "normal_y", "normal_z", "force"]
    rec = np.zeros(2, dtype=[(n, "<f8") for n in names])
    rec["x"] = [0.1, 0.2]
    rec["force"] = [3.0, 4.0]
    msg = PointCloud2(
        height=1, width=2, point_step=56, row_step=112, data=rec.tobytes(),
        fields=[PointField(name=n, offset=8 * i, datatype=PointField.FLOAT64, count=1)
                for i, n in enumerate(names)],
    )
    taxels = msg_to_taxels(msg)
    np.testing.assert_allclose(taxels.positions[:, 0], [0.1, 0.2])
    np.testing.assert_allclose(taxels.forces, [3.0, 4.0])


def test_contact_round_trip() -> None:
    state = ContactState(
        link="right_forearm_link", stamp_ns=42, in_contact=True,
        center=np.array([0.1, -0.2, 0.3]), force=np.array([1.0, 2.0, -3.0]),
        torque=np.array([0.0, 0.5, -1.2]), region_min=np.array([0.0, -0.3, 0.2]),
        region_max=np.array([0.2, -0.1, 0.4]), taxel_count=17,
    )
    back = msg_to_contact(contact_to_msg(state))
    assert back.link == state.link and back.stamp_ns == 42 and back.in_contact
    assert back.taxel_count == 17
    for name in ("center", "force", "torque", "region_min", "region_max"):
        np.testing.assert_array_equal(getattr(back, name), getattr(state, name))


def test_no_contact_state_is_explicit_and_zero() -> None:
    back = msg_to_contact(contact_to_msg(ContactState.no_contact("l", 5)))
    assert not back.in_contact and back.taxel_count == 0
    assert not np.any(back.force) and not np.any(back.center)


def test_contact_with_nan_is_refused() -> None:
    state = ContactState(link="l", stamp_ns=0, in_contact=True, force=np.array([np.nan, 0, 0]))
    with pytest.raises(ContactMessageError, match="force"):
        msg_to_contact(contact_to_msg(state))


def test_contact_from_a_float32_publisher_takes_the_generic_path() -> None:
    names = [*(f"{v}_{a}" for v in ("center", "force", "torque", "region_min", "region_max")
               for a in "xyz"), "taxel_count", "in_contact"]
    rec = np.zeros(1, dtype=[(n, "<f4") for n in names])
    rec["force_y"] = -2.5
    rec["taxel_count"] = 3
    rec["in_contact"] = 1
    msg = PointCloud2(
        height=1, width=1, point_step=4 * len(names), row_step=4 * len(names),
        data=rec.tobytes(),
        fields=[PointField(name=n, offset=4 * i, datatype=PointField.FLOAT32, count=1)
                for i, n in enumerate(names)],
    )
    state = msg_to_contact(msg)
    assert state.in_contact and state.taxel_count == 3
    np.testing.assert_allclose(state.force, [0.0, -2.5, 0.0])
