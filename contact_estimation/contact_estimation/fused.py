"""Compiled per-link sums of the contact estimation: one fused loop over the taxels (numba).

The same masked sums as :meth:`ContactEstimator._link_sums_numpy` (the numpy reference and the
tests' oracle, ``test_fused.py``), in one pass per link instead of a gather and three segmented
reductions: for every taxel with force F > σ_t [N] it adds the geometry row (module docstring of
:mod:`contact_estimation.estimator`) ``[p, −ω n, −ω (p × n)(, ω p, ω)]``, the force-dependent
rows multiplied by F, to its link's sums, and widens the link's box Ω_i of positions p [m].
That is the arithmetic of (5), (9a), (9b) and Sec. IV-B, nothing else: the centre, the torque
about it and its limit are computed from the sums by the estimator, for both kernels alike.
:func:`norm2_and_unchanged` fuses the hot path's range test (‖f‖²) and stuck-skin comparison.

Compiled with ``cache=True``: the machine code is written next to this module (or to numba's
user cache) on the first run and loaded afterwards, so a node starts in well under a second
once it has run once; :func:`warm_up` compiles or loads it ahead of the first frame.
"""

from __future__ import annotations

import numpy as np
from numba import njit
from numpy.typing import NDArray

TABLE_EXTRA = 7
"""Columns after the R geometry sums in a link's table row: Ω_i's min (3), max (3), count."""


@njit(cache=True, nogil=True)
def link_sums(forces: NDArray[np.float64], rows_t: NDArray[np.float64], threshold: float,
              starts: NDArray[np.int64], first: int, last: int,
              out: NDArray[np.float64]) -> None:  # pragma: no cover - compiled, tested via
    # the estimator against the numpy reference (coverage cannot trace machine code)
    """Sums of links ``first`` … ``last − 1`` into ``out[link]`` (R + 7 columns).

    Args:
        forces: taxel normal forces F [N], all links' patches concatenated (N or more).
        rows_t: geometry rows per taxel (N, R), R = 9 or 13, columns as in the estimator.
        threshold: σ_t [N]; a taxel counts when F > σ_t (a NaN never does).
        starts: first taxel column of every link, plus the total (L + 1).
        out: (L, R + 7): ``[Σ row (force rows × F), min p (3), max p (3), count]``; a link
            without a contacting taxel gets zeros, +inf / −inf bounds and count 0.
    """
    width = rows_t.shape[1]
    weighted = width > 9
    for link in range(first, last):
        # Scalar accumulators (kept in registers; the output row is written once).
        px = py = pz = fx = fy = fz = mx = my = mz = 0.0
        wx = wy = wz = w = 0.0
        lx = ly = lz = np.inf
        hx = hy = hz = -np.inf
        count = 0
        for j in range(starts[link], starts[link + 1]):
            force = forces[j]
            if not force > threshold:
                continue
            count += 1
            g = rows_t[j]
            x, y, z = g[0], g[1], g[2]
            px += x
            py += y
            pz += z
            lx, ly, lz = min(lx, x), min(ly, y), min(lz, z)
            hx, hy, hz = max(hx, x), max(hy, y), max(hz, z)
            fx += force * g[3]
            fy += force * g[4]
            fz += force * g[5]
            mx += force * g[6]
            my += force * g[7]
            mz += force * g[8]
            if weighted:
                wx += g[9]
                wy += g[10]
                wz += g[11]
                w += g[12]
        row = out[link]
        row[0], row[1], row[2], row[3], row[4], row[5] = px, py, pz, fx, fy, fz
        row[6], row[7], row[8] = mx, my, mz
        if weighted:
            row[9], row[10], row[11], row[12] = wx, wy, wz, w
        row[width], row[width + 1], row[width + 2] = lx, ly, lz
        row[width + 3], row[width + 4], row[width + 5] = hx, hy, hz
        row[width + 6] = count


@njit(cache=True, nogil=True)
def norm2_and_unchanged(forces: NDArray[np.floating],
                        previous: NDArray[np.float64]) -> tuple[float, bool]:  # pragma: no cover
    """One pass over a new frame's forces [N]: ``(‖f‖² [N²], f == previous element-wise)``.

    The same ‖f‖² as :func:`contact_estimation.estimator.check_forces` (which runs whenever it
    exceeds the range, to name the bad value) and the same comparison as the stuck detector's
    ``np.array_equal``, without a second pass over the arrays.
    """
    norm2 = 0.0
    unchanged = True
    for j in range(forces.shape[0]):
        f = forces[j]
        norm2 += f * f
        if f != previous[j]:
            unchanged = False
    return norm2, unchanged


def warm_up() -> None:
    """Compile (first run) or load (later runs) :func:`link_sums` ahead of the first frame."""
    rows = np.zeros((1, 9))
    link_sums(np.ones(1), rows, 0.0, np.array([0, 1], dtype=np.int64), 0, 1,
              np.zeros((1, 9 + TABLE_EXTRA)))
    norm2_and_unchanged(np.ones(1), np.ones(1))
