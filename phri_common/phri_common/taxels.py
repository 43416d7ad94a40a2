"""The taxel array message: one skin patch's taxels as a ``sensor_msgs/PointCloud2``.

This module is the only encoder/decoder of taxel arrays in phri; every package that publishes or
reads taxels uses it.

Layout (documented in ``docs/interfaces.md``): one point per taxel, ``height = 1``,
little-endian, packed ``float32`` fields

======================  =====  ==========================================================
field                   unit   meaning
======================  =====  ==========================================================
x, y, z                 m      taxel centre in the link frame (``header.frame_id``)
normal_x/y/z            –      outward unit surface normal in the link frame
force                   N      normal force pressing on the taxel (≥ 0 once calibrated)
weight (optional)       –      the paper's per-taxel weight ω (eq. 5); 1 when absent
======================  =====  ==========================================================

The force a taxel exerts on the link is ``-force * normal`` (the person pushes *into* the skin).
"""

from __future__ import annotations

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
from phri_common.records import FloatArray, TaxelArray
from phri_common.stamps import ns_to_stamp, stamp_to_ns

TAXEL_FIELDS: tuple[str, ...] = ("x", "y", "z", "normal_x", "normal_y", "normal_z", "force")
WEIGHT_FIELD = "weight"

_DTYPE = record_dtype([(name, "f4") for name in TAXEL_FIELDS])
_DTYPE_WEIGHTED = record_dtype([(name, "f4") for name in (*TAXEL_FIELDS, WEIGHT_FIELD)])

class TaxelMessageError(CloudFormatError):
    """A message that claims to be a taxel array is malformed."""


def taxels_to_msg(taxels: TaxelArray) -> PointCloud2:
    """Encode a :class:`TaxelArray` as a PointCloud2 (see module docstring for the layout)."""
    return TaxelCloudEncoder(
        taxels.positions, taxels.normals, taxels.frame_id, taxels.weights
    ).encode(taxels.forces, taxels.stamp_ns)


class TaxelCloudEncoder:
    """Encoder for a patch whose geometry is fixed: only the force column changes per frame.

    Pre-packs positions, normals and weights once; :meth:`encode` writes the forces into the
    buffer and hands ``bytes`` to the message (design §5: list conversions are far slower).
    """

    def __init__(
        self,
        positions: FloatArray,
        normals: FloatArray,
        frame_id: str,
        weights: FloatArray | None = None,
    ) -> None:
        # The geometry is validated as a TaxelArray's (same shape rules, same messages).
        n = np.shape(positions)[0] if np.ndim(positions) == 2 else -1
        geometry = TaxelArray(positions, normals, np.zeros(max(n, 0)), weights, frame_id, 0)
        positions, normals, w = geometry.positions, geometry.normals, geometry.weights
        self._records = np.zeros(n, dtype=_DTYPE if w is None else _DTYPE_WEIGHTED)
        for i, axis in enumerate("xyz"):
            self._records[axis] = positions[:, i]
            self._records[f"normal_{axis}"] = normals[:, i]
        if w is not None:
            self._records[WEIGHT_FIELD] = w
        self._fields = point_fields(self._records.dtype)
        self._frame_id = frame_id
        self.size = n

    def _write(self, forces: FloatArray) -> None:
        forces = np.asarray(forces)
        if forces.shape != (self.size,):
            raise ValueError(f"forces must have shape ({self.size},), got {forces.shape}")
        self._records["force"] = forces

    def taxels(self, forces: FloatArray, stamp_ns: int) -> TaxelArray:
        """One frame as the :class:`TaxelArray` a subscriber decodes from :meth:`encode`'s
        message (the same float32 columns, in a copy of its own), for a consumer in the same
        process that skips the message (phri_sim's lock-step runner)."""
        self._write(forces)
        # Read-only views of immutable bytes, as the decoded message's: TaxelArray keeps them.
        columns = len(self._records.dtype.names or ())
        table = np.frombuffer(self._records.tobytes(), dtype=np.float32).reshape(self.size,
                                                                                 columns)
        return TaxelArray(
            positions=table[:, 0:3], normals=table[:, 3:6], forces=table[:, 6],
            weights=table[:, 7] if table.shape[1] > 7 else None,
            frame_id=self._frame_id, stamp_ns=stamp_ns,
        )

    def encode(self, forces: FloatArray, stamp_ns: int) -> PointCloud2:
        """One frame: forces (N,) [N] at ``stamp_ns`` → PointCloud2."""
        self._write(forces)
        itemsize = self._records.dtype.itemsize
        msg = PointCloud2(
            header=Header(stamp=ns_to_stamp(stamp_ns), frame_id=self._frame_id),
            height=1,
            width=self.size,
            fields=self._fields,
            is_bigendian=False,
            point_step=itemsize,
            row_step=itemsize * self.size,
            is_dense=True,
        )
        # Assigned after construction: the constructor's keyword path validates the sequence
        # element by element; the setter takes the bytes as they are (docs/benchmarks.md,
        # "Skin driver").
        msg.data = self._records.tobytes()
        return msg


def msg_to_taxels(msg: PointCloud2) -> TaxelArray:
    """Decode a taxel PointCloud2 (zero-copy views where the layout allows).

    Raises:
        TaxelMessageError: a required field is missing, has the wrong type, or the byte count
            does not match the header.
    """
    require_fields(msg, TAXEL_FIELDS, "taxel array", TaxelMessageError)
    names = [f.name for f in msg.fields]
    try:
        records = cloud_records(msg)
    except CloudFormatError as err:
        raise TaxelMessageError(f"malformed taxel array: {err}") from err
    has_weight = WEIGHT_FIELD in names
    fast = _DTYPE_WEIGHTED if has_weight else _DTYPE
    if records.dtype == fast:
        # Packed float32 columns: view as an (N, k) matrix and slice — no copy.
        table = records.view(np.float32).reshape(records.shape[0], len(fast.names or ()))
        positions, normals, forces = table[:, 0:3], table[:, 3:6], table[:, 6]
        weights = table[:, 7] if has_weight else None
    else:
        for name in (*TAXEL_FIELDS, *((WEIGHT_FIELD,) if has_weight else ())):
            if records.dtype[name].kind != "f":
                raise TaxelMessageError(f"taxel field {name!r} must be floating point")
        positions = np.stack([records[a] for a in ("x", "y", "z")], axis=1)
        normals = np.stack([records[f"normal_{a}"] for a in "xyz"], axis=1)
        forces = np.ascontiguousarray(records["force"])
        weights = np.ascontiguousarray(records[WEIGHT_FIELD]) if has_weight else None
    return TaxelArray(
        positions=positions,
        normals=normals,
        forces=forces,
        weights=weights,
        frame_id=msg.header.frame_id,
        stamp_ns=stamp_to_ns(msg.header.stamp),
    )
