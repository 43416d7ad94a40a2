"""Generic helpers for ``sensor_msgs/PointCloud2`` records with named fields.

phri carries structured records (taxels, contact states) in PointCloud2 so that every ROS tool
understands them (design §3). These helpers build the field list and view ``data`` as a numpy
structured array without copying (``np.frombuffer``); list conversions would be far slower.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray
from sensor_msgs.msg import PointCloud2, PointField

_NUMPY_OF_POINTFIELD: dict[int, np.dtype] = {
    PointField.INT8: np.dtype("i1"),
    PointField.UINT8: np.dtype("u1"),
    PointField.INT16: np.dtype("<i2"),
    PointField.UINT16: np.dtype("<u2"),
    PointField.INT32: np.dtype("<i4"),
    PointField.UINT32: np.dtype("<u4"),
    PointField.FLOAT32: np.dtype("<f4"),
    PointField.FLOAT64: np.dtype("<f8"),
}
_POINTFIELD_OF_NUMPY = {dt: code for code, dt in _NUMPY_OF_POINTFIELD.items()}


class CloudFormatError(ValueError):
    """A PointCloud2 does not have the layout a phri record requires."""


def record_dtype(fields: Sequence[tuple[str, str]]) -> np.dtype:
    """Packed little-endian structured dtype from ``(name, numpy type string)`` pairs."""
    return np.dtype([(name, np.dtype(kind).newbyteorder("<")) for name, kind in fields])


def point_fields(dtype: np.dtype) -> list[PointField]:
    """PointField list describing a packed structured dtype."""
    out = []
    assert dtype.fields is not None
    for name in dtype.names or ():
        field_dtype, offset = dtype.fields[name][:2]
        code = _POINTFIELD_OF_NUMPY.get(field_dtype.newbyteorder("<"))
        if code is None:
            raise TypeError(f"field {name!r}: dtype {field_dtype} has no PointField type")
        out.append(PointField(name=name, offset=offset, datatype=code, count=1))
    return out


_DTYPE_CACHE: dict[tuple[object, ...], np.dtype] = {}
_DTYPE_CACHE_MAX = 64


def cloud_dtype(msg: PointCloud2) -> np.dtype:
    """Structured dtype (with padding to ``point_step``) described by a message's fields.

    Cached per field layout: every frame of a stream has the same layout, and building a numpy
    dtype is slow next to the decoding itself.
    """
    if msg.is_bigendian:
        raise CloudFormatError("big-endian PointCloud2 is not supported")
    key = (msg.point_step, *((f.name, f.offset, f.datatype, f.count) for f in msg.fields))
    cached = _DTYPE_CACHE.get(key)
    if cached is not None:
        return cached
    dtype = _build_cloud_dtype(msg)
    if len(_DTYPE_CACHE) < _DTYPE_CACHE_MAX:
        _DTYPE_CACHE[key] = dtype
    return dtype


def _build_cloud_dtype(msg: PointCloud2) -> np.dtype:
    names, formats, offsets = [], [], []
    for field in msg.fields:
        base = _NUMPY_OF_POINTFIELD.get(field.datatype)
        if base is None:
            raise CloudFormatError(f"field {field.name!r} has unknown datatype {field.datatype}")
        if field.count != 1:
            raise CloudFormatError(f"field {field.name!r} has count {field.count}, expected 1")
        names.append(field.name)
        formats.append(base)
        offsets.append(field.offset)
    try:
        return np.dtype(
            {"names": names, "formats": formats, "offsets": offsets, "itemsize": msg.point_step}
        )
    except ValueError as err:
        raise CloudFormatError(f"inconsistent PointCloud2 fields: {err}") from err


def cloud_records(msg: PointCloud2) -> NDArray[np.void]:
    """Zero-copy structured view of a PointCloud2's points (read-only)."""
    dtype = cloud_dtype(msg)
    count = int(msg.width) * int(msg.height)
    expected = count * int(msg.point_step)
    if msg.row_step != msg.width * msg.point_step:
        raise CloudFormatError(
            f"row_step {msg.row_step} != width {msg.width} × point_step {msg.point_step}"
        )
    if len(msg.data) != expected:
        raise CloudFormatError(
            f"data holds {len(msg.data)} bytes, header says {count} points × "
            f"{msg.point_step} bytes = {expected}"
        )
    records = np.frombuffer(msg.data, dtype=dtype, count=count)
    records.flags.writeable = False  # a view of the message's buffer: never written through
    return records


def require_fields(
    msg: PointCloud2,
    required: Sequence[str],
    what: str,
    error: type[CloudFormatError] = CloudFormatError,
) -> None:
    """Raise ``error`` (a :class:`CloudFormatError`) naming every field ``msg`` lacks."""
    present = {f.name for f in msg.fields}
    missing = [name for name in required if name not in present]
    if missing:
        raise error(f"{what} lacks field(s) {', '.join(missing)}")
