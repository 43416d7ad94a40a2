"""A partner who is a person, not a script: seeded human variability of the waltz (pure).

``--sway SEED`` (:class:`Sway`, :func:`human_variability`) adds three things to the scripted
choreography, all drawn once from ``numpy.random.default_rng(SEED)``, so the same seed gives the
same partner:

* **postural sway**: a standing person's body moves ±1 cm and ±2° at 0.3–1.5 Hz (quiet-stance
  sway; the robot was measured losing the hold with it): in the dancer's own frame
  (forward, left) and in heading, each a sum of :attr:`Sway.components` sines of seeded
  frequency in :attr:`Sway.band` and phase, scaled so the sum never exceeds the amplitude;
* **hesitations**: every 8–20 s of the dance the partner's clock slows smoothly to a halt and
  picks up again (a raised-cosine dip of the clock rate, 2ℓ long, so the dance pauses for ℓ =
  0.3–0.8 s in all; :class:`Hesitations`); the dance ends later by the sum of the ℓ;
* **small deviations from the script**: every step and side step ×(1 + ε), every turn ×(1 + η),
  ε, η ~ N(0, 5 %) clipped to ±10 % (:func:`deviate`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from phri_sim.scenarios.waltz_choreography import Beat

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class Sway:
    """How much a person departs from the script (module docstring).

    Attributes:
        seed: the seed of every draw.
        amplitude: largest postural sway along each of forward and left [m].
        yaw_amplitude: largest postural sway in heading [rad].
        band: frequency range of the sway [Hz].
        components: sines per sway axis.
        hesitation_interval: range of the time between hesitations [s].
        hesitation_length: range of the pause of one hesitation ℓ [s].
        deviation: standard deviation of the relative step and turn deviations [1].
        deviation_limit: their clip [1].
    """

    seed: int
    amplitude: float = 0.01
    yaw_amplitude: float = math.radians(2.0)
    band: tuple[float, float] = (0.3, 1.5)
    components: int = 3
    hesitation_interval: tuple[float, float] = (8.0, 20.0)
    hesitation_length: tuple[float, float] = (0.3, 0.8)
    deviation: float = 0.05
    deviation_limit: float = 0.10

    def __post_init__(self) -> None:
        if self.seed < 0:
            raise ValueError(f"sway seed {self.seed}: must be >= 0")
        lo, hi = self.band
        if not 0.0 < lo <= hi or self.components < 1:
            raise ValueError(f"sway band {self.band} Hz and components {self.components}: "
                             "need 0 < low <= high and >= 1 component")


@dataclass(frozen=True)
class PosturalSway:
    """Sums of sines: (forward, left) [m] and heading [rad] offsets over time."""

    freqs: FloatArray
    """(3, n) frequencies [Hz] of forward, left, heading."""
    phases: FloatArray
    """(3, n) phases [rad]."""
    amps: FloatArray
    """(3, n) amplitudes [m, m, rad]."""

    def at(self, t: float) -> tuple[FloatArray, FloatArray]:
        """(offsets (3) [m, m, rad], their rates (3) [m/s, m/s, rad/s]) at ``t`` [s]."""
        arg = 2.0 * math.pi * self.freqs * t + self.phases
        value = np.sum(self.amps * np.sin(arg), axis=1)
        rate = np.sum(self.amps * 2.0 * math.pi * self.freqs * np.cos(arg), axis=1)
        return value, rate


@dataclass(frozen=True)
class Hesitations:
    """Pauses of the partner's clock (module docstring): the dance time c(t) = t − Σ_k D_k(t),
    D_k the integral of a raised-cosine dip of the clock rate that starts at ``starts[k]`` and
    lasts 2·``lengths[k]`` (so it costs ``lengths[k]`` of dance time)."""

    starts: tuple[float, ...] = ()
    lengths: tuple[float, ...] = ()

    @property
    def total(self) -> float:
        """The dance's delay when every hesitation is over [s]."""
        return float(sum(self.lengths))

    def clock(self, t: float) -> tuple[float, float]:
        """(dance time c(t) [s], clock rate ċ(t) [1]) at sim time ``t`` [s]."""
        c, rate = t, 1.0
        for start, length in zip(self.starts, self.lengths, strict=True):
            width = 2.0 * length
            u = (t - start) / width
            if u <= 0.0:
                continue
            if u >= 1.0:
                c -= length
                continue
            dip = 0.5 - 0.5 * math.cos(2.0 * math.pi * u)  # 0 → 1 → 0: the clock halts mid-way
            c -= length * (u - math.sin(2.0 * math.pi * u) / (2.0 * math.pi))
            rate -= dip
        return c, rate


@dataclass(frozen=True)
class Variability:
    """One partner's draw: sway, hesitations and per-beat deviation factors."""

    sway: PosturalSway
    hesitations: Hesitations
    step_factors: FloatArray
    turn_factors: FloatArray


def human_variability(spec: Sway, beats: int, dance: tuple[float, float]) -> Variability:
    """Draw one partner (module docstring) for a routine of ``beats`` beats danced over sim time
    ``dance`` = (start, end) [s] (hesitations fall inside it)."""
    rng = np.random.default_rng(spec.seed)
    lo, hi = spec.band
    n = spec.components
    freqs = rng.uniform(lo, hi, size=(3, n))
    phases = rng.uniform(0.0, 2.0 * math.pi, size=(3, n))
    weights = rng.uniform(0.5, 1.0, size=(3, n))
    weights /= weights.sum(axis=1, keepdims=True)
    scale = np.array([[spec.amplitude], [spec.amplitude], [spec.yaw_amplitude]])
    starts: list[float] = []
    lengths: list[float] = []
    t = dance[0] + rng.uniform(*spec.hesitation_interval)
    while t < dance[1]:
        starts.append(float(t))
        lengths.append(float(rng.uniform(*spec.hesitation_length)))
        t += 2.0 * lengths[-1] + rng.uniform(*spec.hesitation_interval)
    limit = spec.deviation_limit
    steps = 1.0 + np.clip(rng.normal(0.0, spec.deviation, beats), -limit, limit)
    turns = 1.0 + np.clip(rng.normal(0.0, spec.deviation, beats), -limit, limit)
    return Variability(PosturalSway(freqs, phases, weights * scale),
                       Hesitations(tuple(starts), tuple(lengths)), steps, turns)


def deviate(beats: Sequence[Beat], steps: FloatArray, turns: FloatArray) -> list[Beat]:
    """``beats`` with each step (forward and side) scaled by ``steps[k]`` and each turn by
    ``turns[k]`` (small deviations from the script)."""
    if len(steps) < len(beats) or len(turns) < len(beats):
        raise ValueError(f"{len(beats)} beats need as many factors, got {len(steps)} / "
                         f"{len(turns)}")
    return [replace(b, forward=b.forward * float(steps[k]), left=b.left * float(steps[k]),
                    turn=b.turn * float(turns[k])) for k, b in enumerate(beats)]
