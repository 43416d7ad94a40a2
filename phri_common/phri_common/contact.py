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
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray
from sensor_msgs.msg import PointCloud2
from std_msgs.msg import Header

from phri_common.cloud import CloudFormatError, cloud_records, point_fields, record_dtype
from phri_common.stamps import ns_to_stamp, stamp_to_ns

_VECTORS = ("center", "force", "torque", "region_min", "region_max")
CONTACT_FIELDS: tuple[str, ...] = (
    *(f"{v}_{a}" for v in _VECTORS for a in "xyz"),
    "taxel_count",
    "in_contact",
)
_DTYPE = record_dtype(
    [*((f"{v}_{a}", "f8") for v in _VECTORS for a in "xyz"), ("taxel_count", "u4"),
     ("in_contact", "u1")]
)

Vector3 = NDArray[np.float64]
_FIELDS = point_fields(_DTYPE)
_STRUCT = struct.Struct("<15dIB")  # same packed layout as _DTYPE (itemsize 125)
_PACK = _STRUCT.pack
_LAYOUT = tuple((f.name, f.offset, f.datatype, f.count) for f in _FIELDS)
assert struct.calcsize("<15dIB") == _DTYPE.itemsize


def _zero3() -> Vector3:
    return np.zeros(3)


class ContactMessageError(CloudFormatError):
    """A message that claims to be a contact state is malformed or holds non-finite values."""


@dataclass(frozen=True)
class ContactState:
    """One link's contact state (paper Sec. IV-A/B), all vectors in the link frame.

    Attributes:
        link: link frame name.
        stamp_ns: acquisition time [ns].
        in_contact: whether any taxel is over the threshold.
        center: contact centre ᶦp_η (5) [m].
        force: resultant force ᶦf_η (9a) [N].
        torque: torque about the centre ᶦτ_η (9b), limited [N·m].
        region_min: lower corner of the contact region Ω_i [m].
        region_max: upper corner of the contact region Ω_i [m].
        taxel_count: number of taxels in contact.
    """

    link: str
    stamp_ns: int
    in_contact: bool = False
    center: Vector3 = field(default_factory=_zero3)
    force: Vector3 = field(default_factory=_zero3)
    torque: Vector3 = field(default_factory=_zero3)
    region_min: Vector3 = field(default_factory=_zero3)
    region_max: Vector3 = field(default_factory=_zero3)
    taxel_count: int = 0

    @classmethod
    def no_contact(cls, link: str, stamp_ns: int) -> ContactState:
        """The explicit no-contact state: flag false, count 0, every vector zero."""
        return cls(link=link, stamp_ns=stamp_ns)


def contact_to_msg(state: ContactState) -> PointCloud2:
    """Encode a :class:`ContactState` as a one-point PointCloud2 (≈ 10 µs: no numpy)."""
    data = _PACK(
        *state.center.tolist(),
        *state.force.tolist(),
        *state.torque.tolist(),
        *state.region_min.tolist(),
        *state.region_max.tolist(),
        state.taxel_count,
        1 if state.in_contact else 0,
    )
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
        v = _STRUCT.unpack(msg.data)
        vectors = {name: np.array(v[3 * i : 3 * i + 3]) for i, name in enumerate(_VECTORS)}
        if not all(math.isfinite(x) for x in v[:15]):
            bad = [n for n, vec in vectors.items() if not np.all(np.isfinite(vec))]
            raise ContactMessageError(
                f"contact state of {msg.header.frame_id!r}: non-finite {', '.join(bad)}"
            )
        return ContactState(
            link=msg.header.frame_id,
            stamp_ns=stamp_to_ns(msg.header.stamp),
            in_contact=bool(v[16]),
            taxel_count=int(v[15]),
            **vectors,
        )
    names = {f.name for f in msg.fields}
    missing = [name for name in CONTACT_FIELDS if name not in names]
    if missing:
        raise ContactMessageError(f"contact state lacks field(s) {', '.join(missing)}")
    try:
        records = cloud_records(msg)
    except CloudFormatError as err:
        raise ContactMessageError(f"malformed contact state: {err}") from err
    if records.shape[0] != 1:
        raise ContactMessageError(f"contact state must hold 1 point, got {records.shape[0]}")
    rec = records[0]
    vectors = {
        name: np.array([rec[f"{name}_{a}"] for a in "xyz"], dtype=np.float64) for name in _VECTORS
    }
    for name, vec in vectors.items():
        if not np.all(np.isfinite(vec)):
            raise ContactMessageError(f"contact state of {msg.header.frame_id!r}: {name} = {vec}")
    return ContactState(
        link=msg.header.frame_id,
        stamp_ns=stamp_to_ns(msg.header.stamp),
        in_contact=bool(rec["in_contact"]),
        taxel_count=int(rec["taxel_count"]),
        **vectors,
    )
