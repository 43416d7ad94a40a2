"""The skin driver's 500 Hz pipeline as contact estimation sees it, at any skin sampling rate
(pure, no rclpy).

On the robot the skin boards send a frame every 2 ms; the driver (skin_driver) averages each
taxel over its last 10 frames (the paper's moving average) and publishes every frame; the
controller's 100 Hz cycle takes the newest, which is on average half a frame period old (the
driver and the controller are not synchronised). So the force contact estimation reads at t is

    F̂(t) = (1/W) Σ_{m=0}^{W−1} F(t − a − m·P),    P = 2 ms, W = 10, a = P/2 = 1 ms     (S2)

a 20 ms window whose centre lies 10 ms in the past. The full driver in the loop
(``--skin-driver`` with ``--fidelity paper``: frames of raw counts at 500 Hz through the driver's
parser, calibration and filter) doubles the cost of a run; the realistic plant instead evaluates
(S2) from the simulation's own skin samples (every ``T_s``: 10 ms at the fast fidelity, 2 ms at
the paper's), each F(t − τ) interpolated linearly between the two samples around it. That is a
fixed FIR filter on the samples (:func:`pipeline_weights`; at T_s = 10 ms: 0.25, 0.5, 0.25) with
the same delay as (S2) and the same value for any force linear in time over the window, at no
measurable cost. The filter acts on the true taxel forces before the sensor model
(:mod:`phri_sim.world.skin_sensor`: gain errors, noise, quantisation, dead taxels), so the
noise is that of one sample (the driver's average of 10 would divide it by √10: 0.005 N per
taxel is far below any contact threshold either way).
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Mapping

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]

DRIVER_RATE_HZ = 500.0
"""Frame rate of the skin boards and the driver [Hz] (the paper's, design §2)."""
DRIVER_WINDOW = 10
"""The driver's moving-average window [frames] (the paper's; skin_driver's default)."""
FRAME_AGE = 0.5 / DRIVER_RATE_HZ
"""Mean age of the newest frame when the controller reads it [s]: half a frame period."""


def pipeline_weights(sample_period: float, rate_hz: float = DRIVER_RATE_HZ,
                     window: int = DRIVER_WINDOW, age: float = FRAME_AGE) -> FloatArray:
    """Weights w_j of the samples F(t − j·T_s), j = 0, 1, …, that give (S2) with each frame
    interpolated linearly between the samples around it (module docstring); they sum to 1.

    Args:
        sample_period: T_s, the simulation's skin sampling period [s] (> 0).
        rate_hz: the driver's frame rate 1/P [Hz].
        window: W, frames averaged.
        age: a, age of the newest frame [s] (≥ 0).
    """
    if not (math.isfinite(sample_period) and sample_period > 0.0):
        raise ValueError(f"skin sample period must be > 0 [s], got {sample_period}")
    if window < 1 or not (rate_hz > 0.0 and age >= 0.0):
        raise ValueError(f"driver pipeline: window {window} >= 1, rate {rate_hz} Hz > 0 and "
                         f"age {age} s >= 0 needed")
    period = 1.0 / rate_hz
    taus = age + period * np.arange(window)
    position = taus / sample_period
    lower = np.floor(position + 1e-9).astype(int)
    frac = np.clip(position - lower, 0.0, 1.0)
    weights = np.zeros(int(lower.max()) + 2)
    np.add.at(weights, lower, (1.0 - frac) / window)
    np.add.at(weights, lower + 1, frac / window)
    return np.trim_zeros(weights, "b")


class DriverPipeline:
    """(S2) per skin patch over the simulation's skin samples (module docstring).

    Args:
        sample_period: the skin sampling period T_s [s].
        patches: the patch names.
    """

    def __init__(self, sample_period: float, patches: tuple[str, ...]) -> None:
        self.weights = pipeline_weights(sample_period)
        n = len(self.weights)
        self._history: dict[str, deque[FloatArray | None]] = {
            p: deque([None] * n, maxlen=n) for p in patches}

    def prime(self, forces: Mapping[str, FloatArray]) -> None:
        """Fill every patch's window with ``forces`` [N] (patches not given: none), as if the
        current state had lasted (a hold settled before the run reads its force at once)."""
        for patch, history in self._history.items():
            f = forces.get(patch)
            value = None if f is None or not np.any(f) else np.array(f, dtype=np.float64)
            history.extend([value] * (history.maxlen or 0))

    def holding(self, patch: str) -> bool:
        """Whether a force sampled before still shows in the next output of ``patch`` (the
        samples still inside the window, the oldest leaving it excepted)."""
        history = self._history[patch]
        return any(h is not None for h in list(history)[:-1])

    def push(self, forces: Mapping[str, FloatArray]) -> dict[str, FloatArray]:
        """One skin sample: the true taxel forces [N] of the patches in ``forces`` (every other
        patch had none); returns (S2) [N] for those patches."""
        out: dict[str, FloatArray] = {}
        for patch, history in self._history.items():
            f = forces.get(patch)
            history.appendleft(None if f is None or not np.any(f) else np.asarray(f))
            if f is None:
                continue
            total = np.zeros(np.shape(f))
            for w, h in zip(self.weights, history, strict=False):
                if h is not None:
                    total += w * h
            out[patch] = total
        return out
