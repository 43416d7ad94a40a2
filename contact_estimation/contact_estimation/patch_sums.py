"""Compiled contact estimation: one fused pass per patch frame, a cheap combination per link.

The same masked sums as :meth:`ContactEstimator._link_sums_numpy` (the numpy reference and the
tests' oracle, ``test_fused.py``), computed when a frame arrives instead of at every estimate:

* :func:`take_frame` (per patch frame, from ``set_forces``/``update``): one vectorised pass gives
  the range test's ‖f‖² [N²] and the stuck-skin comparison with the stored frame
  and the span of taxels over σ_t (:func:`scan_frame`); a frame within the range that changed is
  then stored and its patch's sums computed (:func:`patch_sums`) over that span, reading the
  geometry rows of contacting taxels only. A refused or unchanged frame writes nothing.
* :func:`patch_sums`: for every taxel with force F > σ_t [N] it adds the geometry row (module
  docstring of :mod:`contact_estimation.estimator`) ``[p, −ω n, −ω (p × n)(, ω p, ω)]``, the
  force-dependent rows multiplied by F, and widens the patch's box of positions p [m].
* :func:`take_state` (per patch frame, from ``update``): :func:`take_frame`, then the state row
  of the frame's link (:func:`link_states`), in one call; :func:`take_table` (from
  ``update_table``) first sums the frame's geometry columns (the NaN/Inf test of
  :func:`geometry_total`), reading a decoded message's (N, 7 or 8) float32 table in place.
* :func:`link_states` (per estimate): adds the rows of each link's patches (the sums over the
  union of its patches) and turns them into the state row: centre (5), force (9a), torque about
  the centre (9b) with its per-axis limit, region Ω_i (Sec. IV-B). Both kernels use it: the
  numpy reference hands it one row of sums per link.

Compiled with ``cache=True``: the machine code is written next to this module (or to numba's
user cache) on the first run and loaded afterwards, so a node starts in well under a second
once it has run once; :func:`warm_up` compiles or loads it ahead of the first frame.
"""

from __future__ import annotations

import numpy as np
from numba import njit
from numpy.typing import NDArray

TABLE_EXTRA = 7
"""Columns after the R geometry sums in a sums row: the box's min (3), max (3), count."""

STATE_WIDTH = 15
"""Columns of a state row: centre, force, torque, region min, region max (3 each)."""


@njit(cache=True, nogil=True, fastmath={"reassoc"})
def scan_frame(forces: NDArray[np.floating], previous: NDArray[np.float64],
               threshold: float) -> tuple[float, bool, int, int]:  # pragma: no cover
    """One pass over a new frame's forces F [N]: ``(‖F‖² [N²], F == previous element-wise,
    first, last)``, ``first`` … ``last`` the span of taxels with F > σ_t = ``threshold`` [N]
    (``first > last`` when there is none).

    The same ‖F‖² as :func:`contact_estimation.estimator.check_forces` (which runs whenever it
    exceeds the range, to name the bad value), summed in any order (``reassoc``: vectorised;
    NaN and Inf still propagate), and the same comparison as the stuck detector's
    ``np.array_equal``, without a second pass over the arrays; the span lets the sums skip
    the untouched taxels before and after the contact.
    """
    n = forces.shape[0]
    norm2 = 0.0
    differs = False
    first, last = n, -1
    for j in range(n):
        f = forces[j]
        norm2 += f * f
        differs |= f != previous[j]
        hot = f > threshold
        first = min(first, j if hot else n)
        last = max(last, j if hot else -1)
    return norm2, not differs, first, last


@njit(cache=True, nogil=True, fastmath={"reassoc"})
def geometry_total(positions: NDArray[np.floating],
                   normals: NDArray[np.floating]) -> float:  # pragma: no cover
    """Σ of every position [m] and normal component of a frame, in any order (vectorised):
    finite when every element is, so a finite total proves them all finite (a non-finite one
    can also be an overflow of finite values: the caller's exact check clears that). The cheap
    test of :func:`contact_estimation.estimator.check_geometry_values`, compiled for a decoded
    message's strided float32 columns (about 5× faster there than the BLAS products)."""
    total = 0.0
    for j in range(positions.shape[0]):
        total += positions[j, 0] + positions[j, 1] + positions[j, 2]
        total += normals[j, 0] + normals[j, 1] + normals[j, 2]
    return total


@njit(cache=True, nogil=True)
def patch_sums(forces: NDArray[np.float64], rows_t: NDArray[np.float64], c0: int,
               threshold: float, out: NDArray[np.float64], start: int,
               stop: int) -> None:  # pragma: no cover
    """Sums of one patch (taxels ``c0`` … ``c0 + len(forces) − 1`` of ``rows_t``) into ``out``.

    Args:
        forces: the patch's taxel normal forces F [N].
        rows_t: geometry rows per taxel (N, R), R = 9 or 13, columns as in the estimator.
        c0: the patch's first taxel in ``rows_t``.
        threshold: σ_t [N]; a taxel counts when F > σ_t (a NaN never does).
        start, stop: only taxels ``start`` … ``stop − 1`` of the patch are read (``0, n``: all
            of them): the caller knows that no other taxel is over σ_t.
        out: R + 7 columns, ``[Σ row (force rows × F), min p (3), max p (3), count]``; without a
            contacting taxel zeros, +inf / −inf bounds and count 0.
    """
    g = rows_t[c0:c0 + forces.shape[0]]
    weighted = rows_t.shape[1] > 9
    px = py = pz = fx = fy = fz = mx = my = mz = wx = wy = wz = w = 0.0
    lx = ly = lz = np.inf
    hx = hy = hz = -np.inf
    count = 0
    for j in range(start, stop):
        force = forces[j]
        if not force > threshold:
            continue
        count += 1
        x, y, z = g[j, 0], g[j, 1], g[j, 2]
        px += x
        py += y
        pz += z
        # Selects rather than min()/max(): the positions are finite (checked), so the NaN
        # handling of min/max is not needed, and selects keep the loop short.
        lx, ly, lz = (x if x < lx else lx), (y if y < ly else ly), (z if z < lz else lz)
        hx, hy, hz = (x if x > hx else hx), (y if y > hy else hy), (z if z > hz else hz)
        fx += force * g[j, 3]
        fy += force * g[j, 4]
        fz += force * g[j, 5]
        mx += force * g[j, 6]
        my += force * g[j, 7]
        mz += force * g[j, 8]
        if weighted:
            wx += g[j, 9]
            wy += g[j, 10]
            wz += g[j, 11]
            w += g[j, 12]
    out[0], out[1], out[2], out[3], out[4], out[5] = px, py, pz, fx, fy, fz
    out[6], out[7], out[8] = mx, my, mz
    width = rows_t.shape[1]
    if weighted:
        out[9], out[10], out[11], out[12] = wx, wy, wz, w
    out[width], out[width + 1], out[width + 2] = lx, ly, lz
    out[width + 3], out[width + 4], out[width + 5] = hx, hy, hz
    out[width + 6] = count


@njit(cache=True, nogil=True)
def take_frame(forces: NDArray[np.floating], stored: NDArray[np.float64],
               rows_t: NDArray[np.float64], c0: int, threshold: float, limit2: float,
               table: NDArray[np.float64], row: int) -> tuple[float, bool]:  # pragma: no cover
    """A patch frame's forces F [N]: range test, stuck comparison, store and sums, fused.

    Returns ``(‖F‖² [N²], F == stored frame)``. Only when ‖F‖² ≤ ``limit2`` (the range
    ``max_taxel_force²``; NaN fails it) and F differs from the stored frame is F written to
    ``stored[c0:c0 + n]`` and the patch's sums to ``table[row]`` (:func:`patch_sums`);
    otherwise nothing is written (an unchanged frame has the same sums already).
    """
    n = forces.shape[0]
    previous = stored[c0:c0 + n]
    norm2, unchanged, first, last = scan_frame(forces, previous, threshold)
    if norm2 <= limit2 and not unchanged:
        for j in range(n):
            previous[j] = forces[j]
        patch_sums(previous, rows_t, c0, threshold, table[row], first, max(first, last + 1))
    return norm2, unchanged


@njit(cache=True, nogil=True)
def all_patch_sums(stored: NDArray[np.float64], rows_t: NDArray[np.float64],
                   bounds: NDArray[np.int64], threshold: float,
                   table: NDArray[np.float64]) -> None:  # pragma: no cover
    """Every patch's sums from the stored forces [N] (after a new geometry or threshold);
    patch ``k`` holds taxels ``bounds[k]`` … ``bounds[k + 1] − 1``."""
    for k in range(bounds.shape[0] - 1):
        c0, c1 = bounds[k], bounds[k + 1]
        patch_sums(stored[c0:c1], rows_t, c0, threshold, table[k], 0, c1 - c0)


@njit(cache=True, nogil=True)
def _clamp(value: float, limit: float) -> float:  # pragma: no cover
    return -limit if value < -limit else (limit if value > limit else value)


@njit(cache=True, nogil=True)
def link_states(sums: NDArray[np.float64], groups: NDArray[np.int64],
                limit: NDArray[np.float64], first: int, last: int,
                out: NDArray[np.float64], counts: NDArray[np.int64]) -> None:  # pragma: no cover
    """State rows of links ``first`` … ``last − 1`` (eq. 5, 9a, 9b, Ω_i) from sums rows.

    Args:
        sums: rows of R + 7 sums (:func:`patch_sums`); link ``i`` owns rows ``groups[i]`` …
            ``groups[i + 1] − 1`` (its patches), added here: sums add, boxes widen.
        limit: per-axis bound on |torque| [N·m].
        out: ``out[i − first]`` gets ``[centre, force, torque (limited), min p, max p]`` in the
            link frame [m, N, N·m, m, m]; zeros for a link without contact.
        counts: ``counts[i]`` the taxels in contact, 0 for no contact (no taxel over σ_t, or
            only taxels with ω = 0 (declared insensitive): the centre (5) is undefined).
    """
    width = sums.shape[1] - TABLE_EXTRA
    acc = np.empty(sums.shape[1])
    for i in range(first, last):
        acc[:] = sums[groups[i]]
        for r in range(groups[i] + 1, groups[i + 1]):
            for k in range(width):
                acc[k] += sums[r, k]
            for k in range(3):
                acc[width + k] = min(acc[width + k], sums[r, width + k])
                acc[width + 3 + k] = max(acc[width + 3 + k], sums[r, width + 3 + k])
            acc[width + 6] += sums[r, width + 6]
        count = int(acc[width + 6])
        w = float(count) if width == 9 else acc[12]
        state = out[i - first]
        if count == 0 or not w > 0.0:
            state[:] = 0.0
            counts[i] = 0
            continue
        wp = 0 if width == 9 else 9  # Σ ω p: the positions' sum where ω = 1
        cx, cy, cz = acc[wp] / w, acc[wp + 1] / w, acc[wp + 2] / w
        fx, fy, fz = acc[3], acc[4], acc[5]
        # (9b) about the centre: Σ (p − c) × f = Σ p × f − c × Σ f
        state[0], state[1], state[2], state[3], state[4], state[5] = cx, cy, cz, fx, fy, fz
        state[6] = _clamp(acc[6] - (cy * fz - cz * fy), limit[0])
        state[7] = _clamp(acc[7] - (cz * fx - cx * fz), limit[1])
        state[8] = _clamp(acc[8] - (cx * fy - cy * fx), limit[2])
        state[9:15] = acc[width:width + 6]
        counts[i] = count


@njit(cache=True, nogil=True)
def take_state(forces: NDArray[np.floating], stored: NDArray[np.float64],
               rows_t: NDArray[np.float64], c0: int, threshold: float, limit2: float,
               sums: NDArray[np.float64], row: int, groups: NDArray[np.int64],
               limit: NDArray[np.float64], link: int, out: NDArray[np.float64],
               counts: NDArray[np.int64]) -> tuple[float, bool]:  # pragma: no cover
    """:func:`take_frame` of a patch frame's forces F [N], then, when ‖F‖² ≤ ``limit2``, the
    state row of link ``link`` (:func:`link_states`) into ``out[0]`` and ``counts[link]``.
    Returns ``(‖F‖² [N²], F == stored frame)``; ``out`` is not written when ‖F‖² > ``limit2``.
    """
    norm2, unchanged = take_frame(forces, stored, rows_t, c0, threshold, limit2, sums, row)
    if norm2 <= limit2:
        link_states(sums, groups, limit, link, link + 1, out, counts)
    return norm2, unchanged


@njit(cache=True, nogil=True, fastmath={"reassoc"})
def table_geometry_total(table: NDArray[np.floating]) -> float:  # pragma: no cover
    """Σ of a taxel table's positions [m], normals and (8 columns) weights: every column but
    the force (column 6), in any order (``reassoc``: vectorised; NaN and Inf still
    propagate); finite when every element is (see :func:`geometry_total`)."""
    total = 0.0
    if table.shape[1] > 7:
        for j in range(table.shape[0]):
            total += (table[j, 0] + table[j, 1] + table[j, 2] + table[j, 3] + table[j, 4]
                      + table[j, 5] + table[j, 7])
    else:
        for j in range(table.shape[0]):
            total += (table[j, 0] + table[j, 1] + table[j, 2] + table[j, 3] + table[j, 4]
                      + table[j, 5])
    return total


@njit(cache=True, nogil=True)
def take_table(table: NDArray[np.floating], stored: NDArray[np.float64],
               rows_t: NDArray[np.float64], c0: int, threshold: float, limit2: float,
               sums: NDArray[np.float64], row: int, groups: NDArray[np.int64],
               limit: NDArray[np.float64], link: int, out: NDArray[np.float64],
               counts: NDArray[np.int64]) -> tuple[float, float, bool]:  # pragma: no cover
    """A frame as phri's taxel table (N, 7 or 8): columns x, y, z [m], normal x, y, z, force F
    [N] (, weight ω). Returns ``(Σ geometry, ‖F‖² [N²], F == stored frame)``: the geometry sum
    (:func:`table_geometry_total`) first; only when it is finite :func:`take_state` on column
    6 (else ``(Σ, nan, False)`` and nothing written)."""
    total = table_geometry_total(table)
    if not np.isfinite(total):
        return total, np.nan, False
    norm2, unchanged = take_state(table[:, 6], stored, rows_t, c0, threshold, limit2, sums,
                                  row, groups, limit, link, out, counts)
    return total, norm2, unchanged


def warm_up() -> None:
    """Compile (first run) or load (later runs) the kernels ahead of the first frame, for
    float64 and float32 forces, contiguous or a column of a decoded message's (N, 7 or 8)
    float32 table."""
    rows = np.zeros((2, 9))
    stored = np.zeros(2)
    table = np.zeros((1, 9 + TABLE_EXTRA))
    for forces in (np.ones(2), np.ones(2, dtype=np.float32), np.ones((2, 8), np.float32)[:, 6],
                   np.ones((2, 8))[:, 6]):
        take_frame(forces, stored, rows, 0, 0.0, 1.0e6, table, 0)
    all_patch_sums(stored, rows, np.array([0, 2], dtype=np.int64), 0.0, table)
    for matrix in (np.ones((2, 3)), np.ones((2, 8), np.float32)[:, 0:3]):
        geometry_total(matrix, matrix)
    groups, limit = np.array([0, 1], dtype=np.int64), np.ones(3)
    out, counts = np.zeros((1, STATE_WIDTH)), np.zeros(1, dtype=np.int64)
    link_states(table, groups, limit, 0, 1, out, counts)
    for forces in (np.ones(2), np.ones(2, dtype=np.float32), np.ones((2, 8), np.float32)[:, 6]):
        # Writable, and read-only as a TaxelArray's (a composed driver's, a decoded message's).
        frozen = forces.copy() if forces.flags.c_contiguous else forces[:]
        frozen.flags.writeable = False
        for frame in (forces, frozen):
            take_state(frame, stored, rows, 0, 0.0, 1.0e6, table, 0, groups, limit, 0, out,
                       counts)
    for columns in (7, 8):
        frame = np.ones((2, columns), np.float32)
        frame.flags.writeable = False  # a decoded message's table is read-only
        take_table(frame, stored, rows, 0, 0.0, 1.0e6, table, 0, groups, limit, 0, out, counts)
