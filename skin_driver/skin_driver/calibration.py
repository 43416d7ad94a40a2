"""Per-taxel calibration: raw counts → normal force [N] (pure numpy).

Pipeline for every frame of one patch (N taxels, raw counts ``c``):

1. **Gain and offset** (factory calibration, from the layout file):
   ``f = gain · (c − offset)`` [N].
2. **Moving average** over the last ``filter_window`` frames (the paper, Sec. VI: window 10),
   kept as a running sum (cost independent of the window).
3. **Tare** at start-up (and on request): the mean of ``f`` over ``tare_frames`` frames becomes
   each taxel's baseline — except for a taxel whose mean exceeds the factory zero by more than
   ``tare_max_shift`` [N]: that taxel is being touched during tare, so it keeps the factory zero
   and its contact stays visible. Nothing is output until the tare is complete.
4. **Zero-drift compensation** that keeps sustained contacts (see :class:`PatchCalibrator`).
5. **Masking**: taxels marked dead in the layout, and taxels whose raw count has not changed for
   ``stuck_time`` [s] (a frozen ADC channel, a broken trace stuck at 0 or full scale: a live
   taxel always shows noise), output 0 and are counted. Taxels at the saturation count are
   counted as saturated and report their full-scale force (a lower bound of the true force, so a
   hard push is not lost).
6. Output ``max(f_filtered − baseline, 0)`` [N]: the normal force pressing on each taxel.

``CalibrationConfig.kernel`` picks the implementation: ``numpy`` (this module, the reference
and the tests' oracle) or ``numba`` (:mod:`skin_driver.frame_calibration`: the same steps in two
compiled loops over the taxels; the driver node's default).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from phri_common import paper

FloatArray = NDArray[np.float64]
KERNELS: tuple[str, ...] = ("numpy", "numba")
"""Implementations of :meth:`PatchCalibrator.process` (``CalibrationConfig.kernel``)."""


def counts_to_force(
    counts: NDArray[np.integer], gain: FloatArray | float, offset: FloatArray | float
) -> FloatArray:
    """Step 1 of the pipeline: ``f = gain · (c − offset)`` [N] for raw counts ``c`` [count],
    ``gain`` [N/count] and ``offset`` [count] (per taxel or scalar)."""
    return np.asarray(gain * (counts.astype(np.int32, copy=False) - offset), dtype=np.float64)


@dataclass(frozen=True)
class CalibrationConfig:
    """Calibration settings shared by all patches of a driver.

    Attributes:
        default_gain: gain for layouts without a gain column [N/count].
        default_offset: factory zero for layouts without an offset column [count].
        filter_window: moving-average window [frames] (paper: 10); 1 = no filtering.
        tare_frames: frames averaged for the start-up tare; 0 = use the factory zero.
        tare_max_shift: a taxel whose tare mean exceeds its factory zero by more than this is
            considered touched during tare and keeps the factory zero [N].
        drift_time_constant: time constant of the zero tracking of untouched taxels [s];
            0 disables drift compensation.
        drift_band: deviation from the baseline that still counts as "untouched" [N]; also the
            bound on how much of a slowly growing contact the tracking can absorb.
        release_time_constant: time constant with which a baseline above the signal (the
            reading went negative: the taxel was touched during tare, or drifted down) is
            pulled down [s].
        saturation_count: raw count at or above which a taxel is saturated [count].
        stuck_time: a raw count unchanged this long marks the taxel dead until it changes [s];
            0 disables the check.
        min_free_fraction: fraction of live taxels that must be untouched to estimate the
            common-mode drift; below it, touched taxels' baselines are frozen.
        kernel: ``numpy`` (reference) or ``numba`` (:mod:`skin_driver.frame_calibration`, compiled).
    """

    default_gain: float = 0.0005
    default_offset: float = 1000.0
    filter_window: int = paper.FILTER_WINDOW
    tare_frames: int = 100
    tare_max_shift: float = 0.5
    drift_time_constant: float = 60.0
    drift_band: float = 0.03
    release_time_constant: float = 1.0
    saturation_count: int = 65535
    stuck_time: float = 5.0
    min_free_fraction: float = 0.2
    kernel: str = "numpy"

    def __post_init__(self) -> None:
        if self.kernel not in KERNELS:
            raise ValueError(f"calibration setting kernel refused value {self.kernel!r}: "
                             f"allowed {', '.join(KERNELS)}")
        inf = math.inf
        ranges = {  # name → allowed [low, high] (open at 0 for release_time_constant)
            "default_gain": (0.0, inf),
            "default_offset": (-inf, inf),
            "filter_window": (1, 1000),
            "tare_frames": (0, 100_000),
            "tare_max_shift": (0.0, inf),
            "drift_time_constant": (0.0, inf),
            "drift_band": (0.0, inf),
            "release_time_constant": (1e-12, inf),
            "saturation_count": (1, 65535),
            "stuck_time": (0.0, inf),
            "min_free_fraction": (0.0, 1.0),
        }
        for name, (low, high) in ranges.items():
            value = getattr(self, name)
            if not (math.isfinite(value) and low <= value <= high):
                raise ValueError(
                    f"calibration setting {name} refused value {value!r}: allowed "
                    f"[{low:g}, {high:g}], finite"
                )


@dataclass(frozen=True)
class CalibrationStatus:
    """What the calibrator did with the last frame (for diagnostics).

    Attributes:
        tared: the start-up tare is complete (output is valid).
        dead: taxels masked as dead (layout or stuck).
        stuck: of those, taxels masked because their raw count froze.
        saturated: taxels at the saturation count in the last frame.
        touched_at_tare: taxels that kept the factory zero because they were touched during tare.
        max_baseline: largest |baseline| [N] (how far the zero has moved from the factory zero).
    """

    tared: bool
    dead: int
    stuck: int
    saturated: int
    touched_at_tare: int
    max_baseline: float


class PatchCalibrator:
    """Raw counts → calibrated, filtered, drift-compensated normal forces for one patch.

    **Drift compensation — method.** A first-order high-pass (the iCub skin's compensation)
    tracks every taxel's zero with a time constant τ, so a contact held for a few τ decays to
    zero. Here the zero (``baseline``) of a taxel moves only in three cases:

    * the taxel is *untouched*: its deviation ``d = f − baseline`` lies within ``±drift_band``;
      then ``baseline += (Δt/τ) · d`` (it follows slow per-taxel drift);
    * the taxel is *touched* (``d > drift_band``): its own signal is ignored and its baseline
      moves only with the *common-mode* drift, ``(Δt/τ) · mean(d of untouched taxels)``, which
      temperature and supply drift produce on every taxel of a patch alike. A held contact is
      therefore never tracked away: its reading changes only by its own taxel's non-common
      drift during the hold;
    * the reading is *below* the baseline by more than the band (impossible for a pressing
      force): the baseline is too high — it was tared under a light touch, or drifted down —
      and is pulled down with the short ``release_time_constant``.

    A contact that grows more slowly than τ can be absorbed only while it is within the band,
    so the error is bounded by ``drift_band``. Proven with numbers in
    ``test/test_calibration.py`` (a 2 N contact held for 10 min under common-mode drift).
    """

    def __init__(
        self,
        size: int,
        config: CalibrationConfig,
        gains: FloatArray | None = None,
        offsets: FloatArray | None = None,
        dead: NDArray[np.bool_] | None = None,
    ) -> None:
        if size < 1:
            raise ValueError(f"a patch needs at least one taxel, got {size}")
        self.size = size
        self.config = config
        self._gain = np.full(size, config.default_gain) if gains is None else np.array(gains, float)
        self._offset = (
            np.full(size, config.default_offset) if offsets is None else np.array(offsets, float)
        )
        if self._gain.shape != (size,) or self._offset.shape != (size,):
            raise ValueError(f"gains and offsets must have {size} entries")
        self._dead_static = np.zeros(size, bool) if dead is None else np.array(dead, bool)
        window = config.filter_window
        self._ring = np.zeros((window, size))
        self._ring_sum = np.zeros(size)
        self._ring_pos = 0
        self._ring_count = 0
        self._frames_since_resum = 0
        self._baseline = np.zeros(size)
        self._last_counts = np.full(size, -1, dtype=np.int32)
        self._last_change = np.zeros(size)
        self._last_t: float | None = None
        self._touched_at_tare = 0
        self._stuck = np.zeros(size, bool)
        self._saturated = 0
        self._filtered = np.zeros(size)
        if config.kernel == "numba":  # imported here: numba only where it is used
            from skin_driver.frame_calibration import (
                calibrate_counts,
                track_drift_and_output,
                warm_up,
            )

            warm_up()
            self._kernels = (calibrate_counts, track_drift_and_output)
        self.tare()

    @property
    def baseline(self) -> FloatArray:
        """Current per-taxel zero [N] relative to the factory zero (read-only copy)."""
        return self._baseline.copy()

    @property
    def tared(self) -> bool:
        return self._tare_left == 0

    def tare(self) -> None:
        """Start a new tare over the next ``tare_frames`` frames (output pauses meanwhile)."""
        self._tare_left = self.config.tare_frames
        self._tare_sum = np.zeros(self.size)
        if self._tare_left == 0:
            self._baseline[:] = 0.0

    def reset_filter(self) -> None:
        """Empty the moving-average window (after a silence: old frames must not leak in)."""
        self._ring[:] = 0.0
        self._ring_sum[:] = 0.0
        self._ring_count = 0
        self._ring_pos = 0
        self._last_t = None

    def status(self) -> CalibrationStatus:
        dead = self._dead_static | self._stuck
        return CalibrationStatus(
            tared=self.tared,
            dead=int(np.count_nonzero(dead)),
            stuck=int(np.count_nonzero(self._stuck & ~self._dead_static)),
            saturated=self._saturated,
            touched_at_tare=self._touched_at_tare,
            max_baseline=float(np.max(np.abs(self._baseline))),
        )

    def process(self, counts: NDArray[np.integer], t: float) -> FloatArray | None:
        """Calibrate one frame.

        Args:
            counts: (N,) raw counts.
            t: acquisition time [s] (any monotonic origin); sets the drift step Δt.

        Returns:
            (N,) normal forces [N], ≥ 0, or ``None`` while the tare is in progress.

        Raises:
            ValueError: ``counts`` has the wrong shape.
        """
        if counts.shape != (self.size,):
            raise ValueError(f"expected {self.size} taxels, got {counts.shape}")
        if self.config.kernel == "numba":
            return self._process_fused(counts, t)
        return self._process_numpy(counts, t)

    def _step_dt(self, t: float) -> float:
        """Δt [s] since the previous frame, bounded to [0, 0.1] so a pause (silence,
        reconnect) does not make one huge drift step; 0 for the first frame."""
        dt = 0.0 if self._last_t is None else min(max(t - self._last_t, 0.0), 0.1)
        self._last_t = t
        return dt

    def _finish_tare(self) -> None:
        """Tare complete: each taxel's mean becomes its zero unless it was touched (> shift)."""
        mean = self._tare_sum / self.config.tare_frames
        touched = mean > self.config.tare_max_shift
        self._touched_at_tare = int(np.count_nonzero(touched))
        self._baseline = np.where(touched, 0.0, mean)

    def _process_fused(self, counts: NDArray[np.integer], t: float) -> FloatArray | None:
        """:meth:`process` with the compiled kernels (:mod:`skin_driver.frame_calibration`)."""
        calibrate_counts, track_drift_and_output = self._kernels
        cfg = self.config
        window = cfg.filter_window
        full = self._ring_count == window
        self._ring_count = window if full else self._ring_count + 1
        pos = self._ring_pos
        taring = self._tare_left > 0
        self._saturated = calibrate_counts(
            np.ascontiguousarray(counts), self._gain, self._offset,
            cfg.saturation_count, cfg.stuck_time, t, self._last_counts, self._last_change,
            self._stuck, self._ring, self._ring_sum, pos, full, self._ring_count, taring,
            self._tare_sum, self._filtered)
        self._ring_pos = (pos + 1) % window
        self._count_resum()
        dt = self._step_dt(t)
        if taring:
            self._tare_left -= 1
            if self._tare_left == 0:
                self._finish_tare()
            return None
        out = np.empty(self.size)
        track_drift_and_output(
            self._filtered, self._baseline, self._dead_static, self._stuck,
            cfg.drift_time_constant > 0 and dt > 0, cfg.drift_band,
            min(dt / cfg.drift_time_constant, 1.0) if cfg.drift_time_constant > 0 else 0.0,
            min(dt / cfg.release_time_constant, 1.0), cfg.min_free_fraction, out)
        return out

    def _process_numpy(self, counts: NDArray[np.integer], t: float) -> FloatArray | None:
        """:meth:`process` in numpy (the reference)."""
        cfg = self.config
        raw = counts.astype(np.int32)
        force = counts_to_force(raw, self._gain, self._offset)
        saturated = raw >= cfg.saturation_count
        self._saturated = int(np.count_nonzero(saturated))
        if cfg.stuck_time > 0:
            np.copyto(self._last_change, t, where=raw != self._last_counts)
            self._last_counts = raw
            self._stuck = self._last_change <= t - cfg.stuck_time
        dt = self._step_dt(t)
        filtered = self._filter(force)
        if self._tare_left > 0:
            self._tare_sum += force
            self._tare_left -= 1
            if self._tare_left == 0:
                self._finish_tare()
            return None
        if cfg.drift_time_constant > 0 and dt > 0:
            self._track_drift(filtered, dt)
        out = filtered - self._baseline
        np.maximum(out, 0.0, out=out)
        out[self._dead_static | self._stuck] = 0.0
        return out

    def _filter(self, force: FloatArray) -> FloatArray:
        window = self.config.filter_window
        if self._ring_count == window:
            self._ring_sum -= self._ring[self._ring_pos]
        else:
            self._ring_count += 1
        self._ring[self._ring_pos] = force
        self._ring_sum += force
        self._ring_pos = (self._ring_pos + 1) % window
        self._count_resum()
        return self._ring_sum / self._ring_count

    def _count_resum(self) -> None:
        """Re-sum the window every 4096 frames: the running sum would otherwise accumulate
        rounding error. Rows not yet filled are zero, so the full sum is right during warm-up
        too (in place: the compiled kernel holds no reference, but keep one array)."""
        self._frames_since_resum += 1
        if self._frames_since_resum >= 4096:
            self._ring_sum[:] = self._ring.sum(axis=0)
            self._frames_since_resum = 0

    def _track_drift(self, filtered: FloatArray, dt: float) -> None:
        cfg = self.config
        deviation = filtered - self._baseline
        live = ~(self._dead_static | self._stuck)
        free = live & (np.abs(deviation) <= cfg.drift_band)
        below = live & (deviation < -cfg.drift_band)
        n_free = int(np.count_nonzero(free))
        n_live = int(np.count_nonzero(live))
        common = 0.0
        if n_free > 0 and n_free >= cfg.min_free_fraction * n_live:
            common = float(np.sum(deviation, where=free)) / n_free
        alpha = min(dt / cfg.drift_time_constant, 1.0)
        step = np.where(free, deviation, common)
        step *= alpha
        if below.any():
            np.copyto(step, deviation * min(dt / cfg.release_time_constant, 1.0), where=below)
        if n_live < self.size:
            step[~live] = 0.0
        self._baseline += step
