"""Skin sensor model: true taxel forces [N] → the raw ADC counts a skin board sends (pure, seeded).

The footprint model (:mod:`phri_sim.world.skin_footprint`) gives the force ``f_j`` [N] pressing on
each taxel. A real board reports, per taxel ``j`` and sample, an unsigned 16-bit count::

    c_j = clip(round(z_j + (1 + g_j) · f_j / G + n_j), 0, 65535)          (S1)

* ``G`` = :data:`NOMINAL_GAIN` [N/count]: the calibration the driver applies (skin_driver's
  ``default_gain``): one count is the ADC's quantisation step (LSB), 0.5 mN;
* ``g_j`` ~ N(0, ``gain_error_std``): the per-taxel gain error the factory calibration leaves
  (residual sensitivity spread) [-];
* ``z_j`` = :data:`NOMINAL_ZERO` + N(0, ``offset_std``) [count]: the taxel's true zero, off the
  calibrated zero by a per-taxel offset (removed by the driver's tare, never by the model);
* ``n_j`` ~ N(0, ``noise_std`` / G) [count]: noise, independent per taxel and sample;
* dead taxels (``dead_taxels`` per patch, at seeded positions, not declared in the layout):
  gain 0 and no noise, so their count stays at round(z_j) whatever the force (a broken trace;
  the driver's stuck-taxel check masks them after ``stuck_time``).

``round`` is the ADC's quantisation; the clip at 0 and 65535 its range (65535 = saturated).

:meth:`PatchSensor.reading` converts counts back to force as a driver with a *perfect* tare
and no filter would, ``max(G · (c_j − z_j), 0)`` (skin_driver's formula with the true zero): what
the simulator publishes when the skin driver is not in the loop. The gain error, noise,
quantisation and dead taxels stay in that reading, so the estimation error is measured, not
assumed. With the driver in the loop the counts go on the wire instead
(:mod:`phri_sim.world.skin_driver_loop`) and the driver's own tare, moving average and calibration
apply.

The board is skin_driver's simulated board (:class:`~skin_driver.sim_board.SimBoard`), given
the true per-taxel constants (:class:`PatchSensor`). Randomness: the per-taxel constants (g, z,
dead set) are drawn once per patch from ``seed`` and the board id (they belong to the board).
The noise of a sample is a slice of a seeded pool of :data:`NOISE_POOL` Gaussian samples
starting at an offset drawn from a generator seeded likewise (restarted by
:meth:`PatchSensor.reset_noise`): a slice is an order of magnitude cheaper than fresh draws, and
the 500 Hz skin samples up to 1,500 patch frames per simulated second. A taxel gets the same
noise value in two samples only if their offsets coincide (probability 1 / 65,536).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from skin_driver.calibration import CalibrationConfig, counts_to_force
from skin_driver.layout import SkinLayout
from skin_driver.sim_board import SimBoard

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
    """One patch's skin board (S1) and the perfectly tared reading of its counts.

    The board is skin_driver's :class:`~skin_driver.sim_board.SimBoard` (``count = offset +
    force / gain + noise``, rounded and clipped) given the patch's *true* per-taxel constants:
    gain G / (1 + g_j), offset z_j, gain 0 for a dead taxel (its count stays at its zero). The
    noise is added as the force n_j · G / (1 + g_j), which the board turns into n_j counts. The
    driver calibrates with the nominal G and zero.

    Args:
        layout: the patch's layout (nominal calibration).
        config: the model's parameters.
        seed: seed of the per-taxel constants and of the noise.
        board_id: the board's id (also makes every board's constants its own).
    """

    def __init__(self, layout: SkinLayout, config: SensorConfig, seed: int,
                 board_id: int) -> None:
        size = layout.size
        self.layout, self.config, self.board_id, self._seed = layout, config, board_id, seed
        self.size = size
        board = np.random.default_rng([seed, board_id, 0x5E115])
        gain_error = board.normal(0.0, config.gain_error_std, size)
        self.zero = NOMINAL_ZERO + board.normal(0.0, config.offset_std, size)
        """True zero z_j [count]."""
        self.dead = np.zeros(size, bool)
        self.dead[board.choice(size, min(config.dead_taxels, size), replace=False)] = True
        true_gain = NOMINAL_GAIN / np.maximum(1.0 + gain_error, 1e-6)
        true_gain[self.dead] = 0.0
        self._true_layout = replace(layout, gains=true_gain, offsets=self.zero)
        # n_j enters as the force n_j · gain_j: the board turns it into n_j counts (0 for a dead
        # taxel, whose count then stays at its zero).
        self._noise_scale = (config.noise_std / NOMINAL_GAIN) * true_gain
        self._pool = board.standard_normal(NOISE_POOL + size)
        self.reset_noise()

    def reset_noise(self) -> None:
        """A fresh board (sequence 0) and the noise restarted from the seed."""
        self.board = SimBoard(self.board_id, self._true_layout, noise_counts=0.0)
        self._rng = np.random.default_rng([self._seed, self.board_id])

    def _with_noise(self, forces: FloatArray) -> FloatArray:
        if self.config.noise_std <= 0.0:
            return forces
        start = int(self._rng.integers(NOISE_POOL))
        return forces + self._pool[start:start + self.size] * self._noise_scale

    def counts(self, forces: FloatArray, t: float) -> NDArray[np.uint16]:
        """One sample (S1): the (N,) counts for true taxel forces ``forces`` [N] at time ``t``
        [s]."""
        return self.board.counts(self._with_noise(forces), t)

    def frame(self, forces: FloatArray, t: float) -> bytes:
        """One sample as the bytes of a protocol-v1 frame (board time ``t`` [s])."""
        return self.board.frame(self._with_noise(forces), t)

    def reading(self, counts: NDArray[np.integer]) -> FloatArray:
        """Forces [N] a perfectly tared, unfiltered driver reports for ``counts``:
        max(G · (c − z), 0) (module docstring)."""
        return np.maximum(counts_to_force(counts, NOMINAL_GAIN, self.zero), 0.0)
