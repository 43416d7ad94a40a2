"""The contact state message: one link's complete contact state as a one-point PointCloud2.

One message carries everything downstream needs about one link at one instant (design §3), so the
controller never depends on two topics arriving in step. ``header.frame_id`` is the link frame,
``header.stamp`` the acquisition time of the newest taxel frame that went into it. All vectors are
in the link frame. Fields (one point, little-endian):

=====================  =======  ======  =====================================================
field                  type     unit    meaning (paper equation)
=====================  =======  ======  =====================================================
center_x/y/z           float64  m       contact centre ᶦp_η (5)
force_x/y/z            float64  N       resultant force ᶦf_η (9a), on the link
torque_x/y/z           float64  N·m     torque about the centre ᶦτ_η (9b), after the limit
region_min_x/y/z       float64  m       contact region Ω_i lower corner (x⁻, y⁻, z⁻)
region_max_x/y/z       float64  m       contact region Ω_i upper corner (x⁺, y⁺, z⁺)
taxel_count            uint32   –       taxels over the threshold σ_t
in_contact             uint8    –       1 if taxel_count > 0, else 0 (all vectors are then 0)
=====================  =======  ======  =====================================================
"""

from __future__ import annotations

import math
import struct

import numpy as np
from sensor_msgs.msg import PointCloud2
from std_msgs.msg import Header

from phri_common.cloud import (
    CloudFormatError,
    cloud_records,
    point_fields,
    record_dtype,
    require_fields,
)
from phri_common.records import CONTACT_VECTORS, ContactState
from phri_common.stamps import ns_to_stamp, stamp_to_ns

CONTACT_FIELDS: tuple[str, ...] = (
    *(f"{v}_{a}" for v in CONTACT_VECTORS for a in "xyz"),
    "taxel_count",
    "in_contact",
)
_DTYPE = record_dtype(
    [*((f"{v}_{a}", "f8") for v in CONTACT_VECTORS for a in "xyz"), ("taxel_count", "u4"),
     ("in_contact", "u1")]
)

_FIELDS = point_fields(_DTYPE)
_STRUCT = struct.Struct("<15dIB")  # same packed layout as _DTYPE (itemsize 125)
_PACK = _STRUCT.pack
_LAYOUT = tuple((f.name, f.offset, f.datatype, f.count) for f in _FIELDS)
assert struct.calcsize("<15dIB") == _DTYPE.itemsize


class ContactMessageError(CloudFormatError):
    """A message that claims to be a contact state is malformed or holds non-finite values."""


def contact_data(state: ContactState) -> bytes:
    """The one point's bytes of a contact state message (layout in the module docstring)."""
    return _PACK(
        *state.center.tolist(),
        *state.force.tolist(),
        *state.torque.tolist(),
        *state.region_min.tolist(),
        *state.region_max.tolist(),
        state.taxel_count,
        1 if state.in_contact else 0,
    )


def contact_to_msg(state: ContactState) -> PointCloud2:
    """Encode a :class:`ContactState` as a one-point PointCloud2 (no numpy: cheaper per call)."""
    data = contact_data(state)
    msg = PointCloud2(
        header=Header(stamp=ns_to_stamp(state.stamp_ns), frame_id=state.link),
        height=1,
        width=1,
        fields=_FIELDS,
        is_bigendian=False,
        point_step=_DTYPE.itemsize,
        row_step=_DTYPE.itemsize,
        is_dense=True,
    )
    msg.data = data
    return msg


def msg_to_contact(msg: PointCloud2) -> ContactState:
    """Decode a contact-state PointCloud2.

    Raises:
        ContactMessageError: missing fields, not exactly one point, or non-finite values.
    """
    if (
        msg.point_step == _STRUCT.size
        and len(msg.data) == _STRUCT.size
        and msg.width * msg.height == 1
        and not msg.is_bigendian
        and tuple((f.name, f.offset, f.datatype, f.count) for f in msg.fields) == _LAYOUT
    ):
        # Fast path for phri's own layout: one struct unpack instead of a numpy record view.
        values = _STRUCT.unpack(msg.data)
    else:
        values = _generic_values(msg)
    return contact_from_values(msg.header.frame_id, stamp_to_ns(msg.header.stamp), values)


def _generic_values(msg: PointCloud2) -> tuple[float | int, ...]:
    """The 17 values of any contact-state layout (field order of :data:`CONTACT_FIELDS`)."""
    require_fields(msg, CONTACT_FIELDS, "contact state", ContactMessageError)
    try:
        records = cloud_records(msg)
    except CloudFormatError as err:
        raise ContactMessageError(f"malformed contact state: {err}") from err
    if records.shape[0] != 1:
        raise ContactMessageError(f"contact state must hold 1 point, got {records.shape[0]}")
    rec = records[0]
    return tuple(rec[name].item() for name in CONTACT_FIELDS)


def contact_from_values(frame_id: str, stamp_ns: int,
                        values: tuple[float | int, ...]) -> ContactState:
    """A :class:`ContactState` from the 15 vector floats, the count and the flag; finite only
    (also the decoder of :mod:`phri_common.contact_cdr`)."""
    if not math.isfinite(float(sum(values[:15]))) and not all(map(math.isfinite, values[:15])):
        vectors = np.reshape(values[:15], (5, 3))
        bad = [n for n, vec in zip(CONTACT_VECTORS, vectors, strict=True)
               if not np.all(np.isfinite(vec))]
        raise ContactMessageError(
            f"contact state of {frame_id!r}: non-finite {', '.join(bad)}"
        )
    return ContactState.from_row(frame_id, stamp_ns, bool(values[16]), values[:15],
                                 int(values[15]))
