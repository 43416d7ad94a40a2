"""Taxel arrays straight from their serialized (CDR) bytes: the estimation node's cheap input.

The same idea as :mod:`phri_common.contact_cdr` for ``skin/<patch>/taxels``: a subscription
with ``raw=True`` hands over the bytes; :func:`taxels_from_cdr` reads phri's own packed float32
layouts (:class:`phri_common.taxels.TaxelCloudEncoder`, with or without the weight column) as
read-only views of those bytes, and returns ``None`` for any other layout, which the caller
deserializes and decodes with :func:`phri_common.taxels.msg_to_taxels`, the reference. This
skips rclpy's message objects and the copy of the data into them (cost: docs/benchmarks.md,
"Contact estimation").
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from phri_common.cloud import point_fields
from phri_common.contact_cdr import Template, cloud_header, layout_template, matches
from phri_common.records import FloatArray, TaxelArray
from phri_common.taxels import _DTYPE, _DTYPE_WEIGHTED

_WIDTH_OFFSET = 4
"""Offset of ``width`` after ``height`` in the fixed part."""


@lru_cache(maxsize=32)
def _template(weighted: bool, width: int) -> Template:
    dtype = _DTYPE_WEIGHTED if weighted else _DTYPE
    return Template(*layout_template(point_fields(dtype), dtype.itemsize, width))


def taxel_table_from_cdr(data: bytes) -> tuple[str, int, FloatArray] | None:
    """``(frame_id, stamp [ns], table)`` of a serialized PointCloud2 of phri's own layout,
    else ``None``: ``table`` the (N, 7) or, with the weight column, (N, 8) float32 points
    (x, y, z, normal_x, normal_y, normal_z, force (, weight)), a read-only view of ``data``
    (what :meth:`contact_estimation.estimator.ContactEstimator.update_table` reads)."""
    header = cloud_header(data)
    if header is None or len(data) < header[2] + 8:
        return None
    frame_id, stamp_ns, start = header
    width = int.from_bytes(data[start + _WIDTH_OFFSET : start + _WIDTH_OFFSET + 4], "little")
    for weighted in (False, True):
        template = _template(weighted, width)
        if matches(data, start, template):
            columns = 8 if weighted else 7
            offset = start + template.size
            if len(data) < offset + 4 * columns * width:
                return None
            table = np.frombuffer(data, dtype=np.float32, count=columns * width,
                                  offset=offset).reshape(width, columns)
            return frame_id, stamp_ns, table
    return None


def taxels_from_cdr(data: bytes) -> TaxelArray | None:
    """The taxel array in a serialized PointCloud2 of phri's own layout, else ``None``
    (:func:`taxel_table_from_cdr`'s columns as read-only views).

    Raises:
        ValueError: from :class:`TaxelArray` (an empty cloud), as msg_to_taxels.
    """
    frame = taxel_table_from_cdr(data)
    if frame is None:
        return None
    frame_id, stamp_ns, table = frame
    return TaxelArray(positions=table[:, 0:3], normals=table[:, 3:6], forces=table[:, 6],
                      weights=table[:, 7] if table.shape[1] > 7 else None,
                      frame_id=frame_id, stamp_ns=stamp_ns)
