"""Compiled calibration of one skin frame: two fused loops over the taxels (numba).

The same arithmetic as :class:`~skin_driver.calibration.PatchCalibrator`'s numpy path (the
reference and the tests' oracle, ``test_frame_calibration.py``), in two passes over the taxels
instead of about thirty numpy operations, each a pass and an allocation (cost of each:
docs/benchmarks.md, "Skin driver"):

* :func:`calibrate_counts` — step 1 ``f = gain · (c − offset)`` [N], the saturation count, the
  stuck-taxel clock, the moving average (its ring buffer and running sum) and, while taring, the
  tare sum;
* :func:`track_drift_and_output` — the drift compensation (untouched taxels follow their own
  deviation, touched ones the common-mode mean, readings below the zero are released; the
  class docstring of ``PatchCalibrator`` has the method) and the output ``max(f̄ − zero, 0)``,
  zero on dead or stuck taxels.

The one difference from numpy: the common-mode mean is summed in taxel order rather than
pairwise, so the baselines of touched taxels may differ in the last bits.

Compiled with ``cache=True`` (machine code cached next to this module after the first run);
:func:`warm_up` compiles or loads it before the first frame.
"""

from __future__ import annotations

import numpy as np
from numba import njit
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]


@njit(cache=True, nogil=True)
def calibrate_counts(counts: NDArray[np.uint16], gain: FloatArray, offset: FloatArray,
                     saturation: int, stuck_time: float, t: float,
                     last_counts: NDArray[np.int32], last_change: FloatArray,
                     stuck: NDArray[np.bool_], ring: FloatArray, ring_sum: FloatArray,
                     ring_pos: int, ring_full: bool, ring_count: int, taring: bool,
                     tare_sum: FloatArray, filtered: FloatArray,
                     ) -> int:  # pragma: no cover - compiled; tested against the numpy path
    """Pass 1 over the taxels; returns the number of saturated taxels.

    Args:
        counts: (N,) raw counts [count].
        gain, offset: (N,) [N/count], [count].
        saturation: count at or above which a taxel is saturated.
        stuck_time: a count unchanged this long [s] marks the taxel stuck (0 = off).
        t: acquisition time [s].
        last_counts, last_change, stuck: the stuck-taxel clock (updated in place).
        ring, ring_sum: (W, N) moving-average window and its running sum (updated in place);
            ``ring_pos`` the row to overwrite, ``ring_full`` whether it holds a frame to
            subtract first, ``ring_count`` the frames in the window after this one.
        taring, tare_sum: add the unfiltered forces to ``tare_sum`` while taring.
        filtered: (N,) output, the moving average f̄ [N].
    """
    saturated = 0
    threshold = t - stuck_time
    for i in range(counts.shape[0]):
        raw = np.int32(counts[i])
        force = gain[i] * (raw - offset[i])
        if raw >= saturation:
            saturated += 1
        if stuck_time > 0.0:
            if raw != last_counts[i]:
                last_change[i] = t
            last_counts[i] = raw
            stuck[i] = last_change[i] <= threshold
        if ring_full:
            ring_sum[i] -= ring[ring_pos, i]
        ring[ring_pos, i] = force
        ring_sum[i] += force
        filtered[i] = ring_sum[i] / ring_count
        if taring:
            tare_sum[i] += force
    return saturated


@njit(cache=True, nogil=True)
def track_drift_and_output(filtered: FloatArray, baseline: FloatArray,
                           dead: NDArray[np.bool_], stuck: NDArray[np.bool_], track: bool,
                           band: float, alpha: float, release: float,
                           min_free_fraction: float, out: FloatArray,
                           ) -> None:  # pragma: no cover - compiled; tested against numpy
    """Pass 2: move the zeros (``track``; ``alpha = min(Δt/τ, 1)``, ``release =
    min(Δt/τ_release, 1)``, ``band`` [N]) and write ``out = max(f̄ − zero, 0)`` [N], 0 on dead
    or stuck taxels. ``baseline`` is updated in place."""
    n = filtered.shape[0]
    if track:
        n_free = 0
        n_live = 0
        total = 0.0
        for i in range(n):
            if dead[i] or stuck[i]:
                continue
            n_live += 1
            deviation = filtered[i] - baseline[i]
            if abs(deviation) <= band:
                n_free += 1
                total += deviation
        common = 0.0
        if n_free > 0 and n_free >= min_free_fraction * n_live:
            common = total / n_free
        for i in range(n):
            if dead[i] or stuck[i]:
                continue
            deviation = filtered[i] - baseline[i]
            if abs(deviation) <= band:
                baseline[i] += deviation * alpha
            elif deviation < -band:
                baseline[i] += deviation * release
            else:
                baseline[i] += common * alpha
    for i in range(n):
        value = filtered[i] - baseline[i]
        if value < 0.0:
            value = 0.0
        out[i] = 0.0 if (dead[i] or stuck[i]) else value


def warm_up() -> None:
    """Compile (or load from the cache) both kernels for the driver's argument types."""
    n = 2
    f = np.zeros(n)
    b = np.zeros(n, dtype=np.bool_)
    calibrate_counts(np.zeros(n, dtype=np.uint16), f.copy(), f.copy(), 65535, 1.0, 0.0,
                     np.full(n, -1, dtype=np.int32), f.copy(), b.copy(), np.zeros((1, n)),
                     f.copy(), 0, False, 1, True, f.copy(), f.copy())
    track_drift_and_output(f.copy(), f.copy(), b.copy(), b.copy(), True, 0.03, 0.1, 0.1, 0.5,
                           f.copy())
