"""Skin sensor model: true taxel forces [N] → the raw ADC counts a skin board sends (pure, seeded).

The footprint model (:mod:`phri_sim.skin`) gives the force ``f_j`` [N] pressing on each taxel.
A real board reports, per taxel ``j`` and sample, an unsigned 16-bit count::

    c_j = clip(round(z_j + (1 + g_j) · f_j / G + n_j), 0, 65535)          (S1)

* ``G`` = :data:`NOMINAL_GAIN` [N/count]: the calibration the driver applies (skin_driver's
  ``default_gain``): one count is the ADC's quantisation step (LSB), 0.5 mN;
* ``g_j`` ~ N(0, ``gain_error_std``): the per-taxel gain error the factory calibration leaves
  (residual sensitivity spread) [-];
* ``z_j`` = :data:`NOMINAL_ZERO` + N(0, ``offset_std``) [count]: the taxel's true zero, off the
  calibrated zero by a per-taxel offset (removed by the driver's tare, never by the model);
* ``n_j`` ~ N(0, ``noise_std`` / G) [count]: noise, independent per taxel and sample;
* dead taxels (``dead_taxels`` per patch, at seeded positions, not declared in the layout):
  their count stays at round(z_j) whatever the force (a broken trace reads its zero).

``round`` is the ADC's quantisation; the clip at 0 and 65535 its range (65535 = saturated).

:meth:`PatchSensor.reading` converts counts back to force as a driver with a *perfect* tare
and no filter would, ``max(G · (c_j − z_j), 0)`` (skin_driver's formula with the true zero): what
the simulator publishes when the skin driver is not in the loop. The gain error, noise,
quantisation and dead taxels stay in that reading, so the estimation error is measured, not
assumed. With the driver in the loop the counts go on the wire instead
(:mod:`phri_sim.skin_link`) and the driver's own tare, moving average and calibration apply.

Randomness. The per-taxel constants (g, z, dead set) are drawn once per patch from
``seed`` and the patch index (they belong to the board, not to the run's noise). The noise of a
sample is a slice of a seeded pool of Gaussian samples starting at an offset drawn from the
run's generator: ≈ 2 µs for 2,000 taxels instead of 30 µs for fresh draws (the 500 Hz skin
samples 1,500 patch frames per simulated second). A taxel gets the same noise value in two
frames only if their offsets coincide (probability 1 / :data:`NOISE_POOL`); neighbouring
taxels of frames with nearby offsets share shifted values, which no consumer can see.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from skin_driver.calibration import CalibrationConfig, counts_to_force

FloatArray = NDArray[np.float64]

NOMINAL_GAIN = CalibrationConfig().default_gain
"""Calibrated gain G of (S1) [N/count] (= skin_driver's ``default_gain``, the layouts the
simulator writes have no gain column)."""
NOMINAL_ZERO = CalibrationConfig().default_offset
"""Calibrated zero of (S1) [count] (= skin_driver's ``default_offset``)."""
FULL_SCALE = 65535
"""Largest count (16-bit ADC) [count]."""
NOISE_POOL = 1 << 16
"""Gaussian samples in a patch's noise pool (module docstring)."""


@dataclass(frozen=True)
class SensorConfig:
    """Sensor model parameters (module docstring, eq. S1).

    Attributes:
        noise_std: per-taxel noise, standard deviation [N] (0 = noiseless).
        gain_error_std: per-taxel relative gain error, standard deviation [-].
        offset_std: per-taxel zero offset, standard deviation [count].
        dead_taxels: taxels per patch whose count never moves [-].
    """

    noise_std: float = 0.005
    gain_error_std: float = 0.05
    offset_std: float = 20.0
    dead_taxels: int = 3

    def __post_init__(self) -> None:
        limits = {"noise_std": 10.0, "gain_error_std": 0.5, "offset_std": 5000.0,
                  "dead_taxels": 1000}
        for name, high in limits.items():
            value = getattr(self, name)
            if not (math.isfinite(value) and 0 <= value <= high):
                raise ValueError(f"skin sensor setting {name} refused value {value!r}: allowed "
                                 f"[0, {high:g}]")


class PatchSensor:
    """One patch's sensor: true forces → counts (S1) and the perfectly tared reading.

    Args:
        size: taxels of the patch.
        config: the model's parameters.
        seed: seed of the per-taxel constants and the noise pool.
        patch_index: index of the patch (gives every board its own constants).
    """

    def __init__(self, size: int, config: SensorConfig, seed: int, patch_index: int) -> None:
        if size < 1:
            raise ValueError(f"a patch needs at least one taxel, got {size}")
        self.size, self.config = size, config
        board = np.random.default_rng([seed, patch_index, 0x5E115])
        gain_error = board.normal(0.0, config.gain_error_std, size)
        self.sensitivity = np.maximum(1.0 + gain_error, 0.0) / NOMINAL_GAIN
        """(1 + g_j) / G [count/N]."""
        self.zero = NOMINAL_ZERO + board.normal(0.0, config.offset_std, size)
        """True zero z_j [count]."""
        self.dead = np.zeros(size, bool)
        self.dead[board.choice(size, min(config.dead_taxels, size), replace=False)] = True
        self._dead_counts = np.clip(np.rint(self.zero[self.dead]), 0, FULL_SCALE)
        sigma = config.noise_std / NOMINAL_GAIN
        self._pool = board.normal(0.0, sigma, NOISE_POOL + size) if sigma > 0.0 else None

    def counts(self, forces: FloatArray, rng: np.random.Generator) -> NDArray[np.uint16]:
        """One sample (S1): the (N,) counts for true taxel forces ``forces`` [N] (≥ 0);
        draws the noise offset from ``rng``."""
        if self._pool is not None:
            start = int(rng.integers(NOISE_POOL))
            x = self.zero + self._pool[start:start + self.size]
        else:
            x = self.zero.copy()
        if forces.any():
            x += forces * self.sensitivity
        x[self.dead] = self._dead_counts
        np.rint(x, out=x)
        np.clip(x, 0.0, FULL_SCALE, out=x)
        return x.astype("<u2")

    def reading(self, counts: NDArray[np.integer]) -> FloatArray:
        """Forces [N] a perfectly tared, unfiltered driver reports for ``counts``:
        max(G · (c − z), 0) (module docstring)."""
        return np.maximum(counts_to_force(counts, NOMINAL_GAIN, self.zero), 0.0)
