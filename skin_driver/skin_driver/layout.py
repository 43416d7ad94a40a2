"""Skin patch layouts: taxel geometry and per-taxel calibration in the link frame (pure numpy).

A :class:`SkinLayout` describes one skin patch: the link it is glued to, each taxel's centre and
outward unit normal in that link's frame (the paper's ᶦp_σij, Sec. III-B: taxels are rigidly
attached, so their pose is the link's), the paper's optional per-taxel weight ω (eq. 5), and the
per-taxel calibration the driver applies (gain [N/count], offset [count], dead flag).

The generators :func:`rectangular_patch` and :func:`cylindrical_patch` place square taxels of
:data:`TAXEL_PITCH` = 7.5 mm (the paper's skin, Sec. III-B). The simulator uses the same
generators, so the driver and the simulated skin agree on taxel order and geometry.

Layout file (``save_layout`` / ``load_layout``; specified in ``docs/skin_driver.md``): a YAML
document with a header and one text table line per taxel, in taxel (board payload) order::

    # phri skin layout: one line per taxel, in board payload order.
    format: phri_skin_layout
    version: 1
    patch: left_forearm
    link: left_forearm_link
    taxel_count: 2
    columns: [x, y, z, normal_x, normal_y, normal_z, weight, gain, offset, dead]
    units: {x: m, y: m, z: m, gain: N/count, offset: count}
    taxels: |
      0.000000 0.000000 0.050000 0.000000 0.000000 1.000000 1 0.0005 1000 0
      0.007500 0.000000 0.050000 0.000000 0.000000 1.000000 1 0.0005 1000 0

``x … normal_z`` are required; ``weight``, ``gain``, ``offset``, ``dead`` are optional columns.
"""

from __future__ import annotations

import io
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import yaml
from numpy.typing import ArrayLike, NDArray

TAXEL_PITCH = 0.0075
"""Taxel pitch of the paper's skin [m] (7.5 mm squares, Sec. III-B)."""

LAYOUT_FORMAT = "phri_skin_layout"
LAYOUT_VERSION = 1
REQUIRED_COLUMNS = ("x", "y", "z", "normal_x", "normal_y", "normal_z")
OPTIONAL_COLUMNS = ("weight", "gain", "offset", "dead")
MAX_LAYOUT_TAXELS = 16384

FloatArray = NDArray[np.float64]


class LayoutError(ValueError):
    """A layout (object or file) is malformed; the message says what and where."""


def _vec3(value: ArrayLike, what: str) -> FloatArray:
    v = np.asarray(value, dtype=np.float64).reshape(-1)
    if v.shape != (3,) or not np.all(np.isfinite(v)):
        raise LayoutError(f"{what} must be 3 finite numbers, got {value!r}")
    return v


def _unit(value: ArrayLike, what: str) -> FloatArray:
    v = _vec3(value, what)
    norm = float(np.linalg.norm(v))
    if norm < 1e-9:
        raise LayoutError(f"{what} must be a non-zero vector, got {value!r}")
    return v / norm


@dataclass(frozen=True, eq=False)
class SkinLayout:
    """One skin patch in its link frame.

    Attributes:
        patch: patch name (topic ``skin/<patch>/taxels``).
        link: link frame the geometry is expressed in (``header.frame_id``).
        positions: (N, 3) taxel centres [m].
        normals: (N, 3) outward unit surface normals (normalised on construction).
        weights: (N,) the paper's ω (eq. 5) or ``None`` (all ones).
        gains: (N,) calibration gain [N/count] or ``None`` (the driver's default).
        offsets: (N,) factory zero [count] or ``None`` (the driver's default).
        dead: (N,) bool, taxels known to be broken, or ``None`` (none).

    Raises:
        LayoutError: shapes disagree, values are non-finite, a normal is zero, a weight or gain
            is negative, or the patch has no taxel.
    """

    patch: str
    link: str
    positions: FloatArray
    normals: FloatArray
    weights: FloatArray | None = None
    gains: FloatArray | None = None
    offsets: FloatArray | None = None
    dead: NDArray[np.bool_] | None = None

    def __post_init__(self) -> None:
        if not self.patch or not self.link:
            raise LayoutError("a layout needs a non-empty patch name and link name")
        pos = np.ascontiguousarray(self.positions, dtype=np.float64)
        nrm = np.ascontiguousarray(self.normals, dtype=np.float64)
        if pos.ndim != 2 or pos.shape[1] != 3 or not 1 <= pos.shape[0] <= MAX_LAYOUT_TAXELS:
            raise LayoutError(
                f"patch {self.patch!r}: positions must be (N, 3) with 1…{MAX_LAYOUT_TAXELS} "
                f"taxels, got {pos.shape}"
            )
        n = pos.shape[0]
        if nrm.shape != (n, 3):
            raise LayoutError(f"patch {self.patch!r}: normals must be ({n}, 3), got {nrm.shape}")
        for name, arr in (("positions", pos), ("normals", nrm)):
            bad = np.flatnonzero(~np.all(np.isfinite(arr), axis=1))
            if bad.size:
                raise LayoutError(f"patch {self.patch!r}: non-finite {name} at taxel {bad[0]}")
        lengths = np.linalg.norm(nrm, axis=1)
        if np.any(lengths < 1e-6):
            raise LayoutError(
                f"patch {self.patch!r}: zero normal at taxel {int(np.argmin(lengths))}"
            )
        object.__setattr__(self, "positions", pos)
        object.__setattr__(self, "normals", nrm / lengths[:, None])
        for name in ("weights", "gains", "offsets"):
            value = getattr(self, name)
            if value is None:
                continue
            arr = np.ascontiguousarray(value, dtype=np.float64)
            if arr.shape != (n,) or not np.all(np.isfinite(arr)):
                raise LayoutError(f"patch {self.patch!r}: {name} must be {n} finite numbers")
            if name != "offsets" and np.any(arr < 0):
                raise LayoutError(f"patch {self.patch!r}: {name} must be ≥ 0")
            object.__setattr__(self, name, arr)
        if self.dead is not None:
            dead = np.asarray(self.dead).astype(bool)
            if dead.shape != (n,):
                raise LayoutError(f"patch {self.patch!r}: dead must have {n} entries")
            object.__setattr__(self, "dead", dead)

    @property
    def size(self) -> int:
        """Number of taxels N."""
        return int(self.positions.shape[0])


def rectangular_patch(
    patch: str,
    link: str,
    rows: int,
    cols: int,
    *,
    center: ArrayLike = (0.0, 0.0, 0.0),
    col_axis: ArrayLike = (1.0, 0.0, 0.0),
    row_axis: ArrayLike = (0.0, 1.0, 0.0),
    pitch: float = TAXEL_PITCH,
) -> SkinLayout:
    """A flat ``rows × cols`` grid of taxels centred on ``center`` (link frame).

    Taxel ``k = r * cols + c`` sits at
    ``center + (c - (cols-1)/2) * pitch * col_axis + (r - (rows-1)/2) * pitch * row_axis``;
    its outward normal is ``col_axis × row_axis``.

    Args:
        patch: patch name.
        link: link frame name.
        rows, cols: grid size (≥ 1).
        center: grid centre [m].
        col_axis: direction along a row (columns advance along it); normalised.
        row_axis: direction rows advance along; made orthogonal to ``col_axis``.
        pitch: taxel spacing [m].

    Raises:
        LayoutError: non-positive sizes or pitch, or parallel axes.
    """
    if rows < 1 or cols < 1:
        raise LayoutError(f"rows and cols must be ≥ 1, got {rows} × {cols}")
    if not (math.isfinite(pitch) and pitch > 0):
        raise LayoutError(f"pitch must be a positive length [m], got {pitch}")
    u = _unit(col_axis, "col_axis")
    v = _vec3(row_axis, "row_axis")
    v = v - (v @ u) * u
    if np.linalg.norm(v) < 1e-9:
        raise LayoutError("row_axis must not be parallel to col_axis")
    v = v / np.linalg.norm(v)
    c = _vec3(center, "center")
    r_idx, c_idx = np.divmod(np.arange(rows * cols), cols)
    du = (c_idx - (cols - 1) / 2.0) * pitch
    dv = (r_idx - (rows - 1) / 2.0) * pitch
    positions = c + du[:, None] * u + dv[:, None] * v
    normals = np.tile(np.cross(u, v), (rows * cols, 1))
    return SkinLayout(patch=patch, link=link, positions=positions, normals=normals)


def cylindrical_patch(
    patch: str,
    link: str,
    radius: float,
    axial_range: tuple[float, float],
    *,
    angle_range: tuple[float, float] = (0.0, 2.0 * math.pi),
    axis_point: ArrayLike = (0.0, 0.0, 0.0),
    axis: ArrayLike = (0.0, 0.0, 1.0),
    reference: ArrayLike | None = None,
    pitch: float = TAXEL_PITCH,
) -> SkinLayout:
    """Taxels on a cylinder of ``radius`` around a link-frame axis, normals radially outward.

    The axis passes through ``axis_point`` along ``axis``. A taxel at axial coordinate ``s`` and
    angle ``θ`` sits at ``axis_point + s * a + radius * (cos θ * e1 + sin θ * e2)``, where
    ``a`` is the unit axis, ``e1`` the part of ``reference`` orthogonal to ``a`` (default: the
    link-frame x, y or z axis least aligned with ``a``) and ``e2 = a × e1``.

    Placement: ``n_s = max(1, ⌊(s1 - s0) / pitch⌋)`` rings spaced ``pitch`` apart, centred in
    ``axial_range``; per ring ``n_θ = max(1, ⌊radius (θ1 - θ0) / pitch⌋)`` taxels at
    ``θ0 + (m + ½) Δθ`` with ``Δθ = (θ1 - θ0) / n_θ``, so the arc pitch is ≥ ``pitch`` and no
    two taxel squares overlap. Index ``k = ring * n_θ + m`` (angle varies fastest).

    Args:
        patch: patch name.
        link: link frame name.
        radius: cylinder radius [m] (the skin surface).
        axial_range: (s0, s1) along the axis from ``axis_point`` [m], s1 > s0.
        angle_range: (θ0, θ1) [rad], 0 < θ1 - θ0 ≤ 2π.
        axis_point: a point on the axis [m].
        axis: axis direction (normalised).
        reference: direction of θ = 0 (projected orthogonal to the axis).
        pitch: taxel spacing [m].

    Raises:
        LayoutError: non-positive radius, pitch or ranges, or a reference parallel to the axis.
    """
    if not (math.isfinite(radius) and radius > 0):
        raise LayoutError(f"radius must be a positive length [m], got {radius}")
    if not (math.isfinite(pitch) and pitch > 0):
        raise LayoutError(f"pitch must be a positive length [m], got {pitch}")
    s0, s1 = (float(x) for x in axial_range)
    t0, t1 = (float(x) for x in angle_range)
    if not (math.isfinite(s0) and math.isfinite(s1) and s1 > s0):
        raise LayoutError(f"axial_range must be (s0, s1) with s1 > s0 [m], got {axial_range}")
    if not (math.isfinite(t0) and math.isfinite(t1) and 0 < t1 - t0 <= 2 * math.pi + 1e-12):
        raise LayoutError(f"angle_range must span (0, 2π] [rad], got {angle_range}")
    a = _unit(axis, "axis")
    if reference is None:
        reference = np.eye(3)[int(np.argmin(np.abs(a)))]
    e1 = _vec3(reference, "reference")
    e1 = e1 - (e1 @ a) * a
    if np.linalg.norm(e1) < 1e-9:
        raise LayoutError("reference must not be parallel to the axis")
    e1 = e1 / np.linalg.norm(e1)
    e2 = np.cross(a, e1)
    # A tiny tolerance keeps an exact multiple of the pitch from losing a taxel to rounding.
    n_s = max(1, math.floor((s1 - s0) / pitch + 1e-9))
    n_t = max(1, math.floor(radius * (t1 - t0) / pitch + 1e-9))
    s = (s0 + s1) / 2.0 + (np.arange(n_s) - (n_s - 1) / 2.0) * pitch
    theta = t0 + (np.arange(n_t) + 0.5) * (t1 - t0) / n_t
    ss = np.repeat(s, n_t)
    tt = np.tile(theta, n_s)
    radial = np.cos(tt)[:, None] * e1 + np.sin(tt)[:, None] * e2
    p0 = _vec3(axis_point, "axis_point")
    positions = p0 + ss[:, None] * a + radius * radial
    return SkinLayout(patch=patch, link=link, positions=positions, normals=radial)


def cylinder_taxels(count: int, radius: float = 0.06) -> tuple[FloatArray, FloatArray]:
    """Positions and normals of ``count`` taxels on a cylinder along the x axis (synthetic skin).

    Rings of :func:`cylindrical_patch` at the 7.5 mm pitch, ``radius`` [m], starting at x = 0;
    the first ``count`` taxels are returned as ``(count, 3)`` arrays [m] and unit normals. One
    layout holds at most :data:`~skin_driver.protocol.MAX_TAXELS` taxels (the wire protocol's
    limit), so larger sets join layouts of at most 100 rings end to end along the axis.
    Benchmarks and tests use it for skins of any size.
    """
    if count < 1:
        raise LayoutError(f"count must be a positive number of taxels, got {count}")
    per_ring = max(1, math.floor(2 * math.pi * radius / TAXEL_PITCH + 1e-9))
    rings = math.ceil(count / per_ring)
    positions, normals = [], []
    for first in range(0, rings, 100):
        start = first * TAXEL_PITCH
        layout = cylindrical_patch(
            "synthetic", "link", radius,
            (start, start + min(100, rings - first) * TAXEL_PITCH + 1e-9),
            axis=(1.0, 0.0, 0.0),
        )
        positions.append(layout.positions)
        normals.append(layout.normals)
    return np.concatenate(positions)[:count], np.concatenate(normals)[:count]


def save_layout(layout: SkinLayout, path: str | Path) -> None:
    """Write ``layout`` as a layout file (see module docstring)."""
    columns = list(REQUIRED_COLUMNS)
    blocks: list[NDArray[np.float64]] = [layout.positions, layout.normals]
    fmts = ["%.6f"] * 6
    for name in OPTIONAL_COLUMNS:
        value = getattr(layout, "weights" if name == "weight" else "gains" if name == "gain"
                        else "offsets" if name == "offset" else "dead")
        if value is not None:
            columns.append(name)
            blocks.append(np.asarray(value, dtype=np.float64)[:, None])
            fmts.append("%d" if name == "dead" else "%.9g")
    table = io.StringIO()
    np.savetxt(table, np.hstack(blocks), fmt=fmts)
    body = "".join("  " + line + "\n" for line in table.getvalue().splitlines())
    header = {
        "format": LAYOUT_FORMAT,
        "version": LAYOUT_VERSION,
        "patch": layout.patch,
        "link": layout.link,
        "taxel_count": layout.size,
        "columns": columns,
    }
    text = (
        "# phri skin layout: one line per taxel, in board payload order.\n"
        "# x, y, z: taxel centre [m] in the link frame; normal_*: outward unit normal;\n"
        "# weight: the paper's ω (eq. 5); gain [N/count]; offset [count]; dead: 1 = masked.\n"
        + yaml.safe_dump(header, sort_keys=False, default_flow_style=None)
        + "units: {x: m, y: m, z: m, gain: N/count, offset: count}\n"
        + "taxels: |\n"
        + body
    )
    Path(path).write_text(text, encoding="utf-8")


def _loader() -> Any:
    return getattr(yaml, "CSafeLoader", yaml.SafeLoader)


def load_layout(path: str | Path) -> SkinLayout:
    """Read a layout file.

    Raises:
        LayoutError: unreadable file, wrong format or version, unknown or missing columns,
            a table whose size disagrees with ``taxel_count`` or the columns, or values the
            :class:`SkinLayout` checks refuse. The message names the file.
    """
    path = Path(path)
    try:
        doc = yaml.load(path.read_text(encoding="utf-8"), Loader=_loader())
    except (OSError, UnicodeDecodeError, yaml.YAMLError) as err:
        raise LayoutError(f"layout file {path}: cannot read: {err}") from err
    if not isinstance(doc, dict) or doc.get("format") != LAYOUT_FORMAT:
        raise LayoutError(f"layout file {path}: not a {LAYOUT_FORMAT} document")
    if doc.get("version") != LAYOUT_VERSION:
        raise LayoutError(
            f"layout file {path}: version {doc.get('version')!r} is not supported "
            f"(this driver reads version {LAYOUT_VERSION})"
        )
    try:
        columns = [str(c) for c in doc["columns"]]
        patch, link = str(doc["patch"]), str(doc["link"])
        count = int(doc["taxel_count"])
        text = str(doc["taxels"])
    except (KeyError, TypeError, ValueError) as err:
        raise LayoutError(f"layout file {path}: missing or invalid header field {err}") from err
    unknown = [c for c in columns if c not in REQUIRED_COLUMNS + OPTIONAL_COLUMNS]
    missing = [c for c in REQUIRED_COLUMNS if c not in columns]
    if unknown or missing or len(set(columns)) != len(columns):
        raise LayoutError(
            f"layout file {path}: columns {columns}: unknown {unknown}, missing {missing}"
        )
    if not 1 <= count <= MAX_LAYOUT_TAXELS:
        raise LayoutError(f"layout file {path}: taxel_count {count} outside 1…{MAX_LAYOUT_TAXELS}")
    try:
        values = np.array(text.split(), dtype=np.float64)
    except ValueError as err:
        raise LayoutError(f"layout file {path}: non-numeric entry in taxels: {err}") from err
    if values.size != count * len(columns):
        raise LayoutError(
            f"layout file {path}: taxels table holds {values.size} numbers, expected "
            f"taxel_count {count} × {len(columns)} columns"
        )
    table = values.reshape(count, len(columns))
    col = {name: table[:, i] for i, name in enumerate(columns)}
    try:
        return SkinLayout(
            patch=patch,
            link=link,
            positions=np.stack([col["x"], col["y"], col["z"]], axis=1),
            normals=np.stack([col[f"normal_{a}"] for a in "xyz"], axis=1),
            weights=col.get("weight"),
            gains=col.get("gain"),
            offsets=col.get("offset"),
            dead=None if "dead" not in col else col["dead"] != 0,
        )
    except LayoutError as err:
        raise LayoutError(f"layout file {path}: {err}") from err
