"""What the partner feels of the robot's motion, from a run's recorded signals (pure, no rclpy).

Inputs are series sampled once per control period (docs/phri_sim.md, "Following metrics", F9–F13):

* lag of smoothed rates (F9): each rate is the central difference of the (unwrapped) series,
  smoothed by a centred moving average of :data:`SMOOTHING` = 0.2 s (a period-to-period
  difference is dominated by the loop's own ripple: unsmoothed, the yaw rates' best match was a
  spurious 0.03 s); τ maximises the normalised cross-correlation
  ρ(τ) = Σ r_p(t)·r_b(t+τ) / (‖r_p‖ ‖r_b‖) over the overlap, refined between samples by a parabola
  through the best three shifts; τ > 0: the robot comes later. ``None`` when either rate is
  zero, the follower's rate is below :data:`LAG_MIN_AMPLITUDE` of the leader's (RMS: a robot
  that hardly moves has no lag, only the partner's push on its servos), the best shift lies at
  the end of the search range (no peak inside it) or ρ < :data:`LAG_MIN_CORRELATION`
  (unrelated motions);
* accelerations and jerks (F10): per axis |Δv / Δt| and |Δa / Δt| of a velocity series (a
  command or a measured twist), their 99th percentile and maximum;
* the force's fluctuation above 1 Hz (F11): an 8th-order zero-phase Butterworth high-pass at
  :data:`FLUCTUATION_CUTOFF` (:func:`high_pass`), its RMS and largest magnitude, and the
  frequency of the largest peak of its spectrum;
* time to rest after the partner stops (F12): the partner is *still* while its smoothed speed is
  below :data:`PARTNER_STILL_SPEED` and its smoothed yaw rate below :data:`PARTNER_STILL_RATE`; a
  stop is a still stretch of at least :data:`MIN_STOP` (a close in the waltz, the end of a
  lead). In each stop the robot comes to rest at the first sample from which its base speed stays
  below :data:`REST_SPEED` and its yaw rate below :data:`REST_RATE` for :data:`MIN_REST`
  (inside the stop); time to rest = that sample − the stop's start, ``None`` when it never
  comes to rest in the stop (the partner's next motion may begin before the stop's end is
  detected, so rest is not required to the end).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]

SMOOTHING = 0.2
"""Width of the centred moving average on rates before they are correlated (F9) [s]."""
LAG_MIN_CORRELATION = 0.5
"""Below this normalised cross-correlation no lag is reported (F9) [1]."""
LAG_MIN_AMPLITUDE = 0.05
"""Below this ratio of the follower's to the leader's RMS rate no lag is reported (F9) [1]."""
FLUCTUATION_CUTOFF = 1.0
"""High-pass corner of the force fluctuation (F11) [Hz]."""
FLUCTUATION_ORDER = 8
"""Order of its Butterworth high-pass (run forwards and backwards) (F11)."""
PARTNER_STILL_SPEED = 0.005
"""The partner is still below this smoothed planar speed (F12) [m/s]."""
PARTNER_STILL_RATE = 0.02
"""… and below this smoothed yaw rate (F12) [rad/s]."""
MIN_STOP = 2.0
"""A still stretch of the partner this long is a stop (F12) [s]."""
REST_SPEED = 0.002
"""The robot base is at rest below this planar speed (2 mm/s; F12) [m/s]."""
REST_RATE = 0.005
"""… and below this yaw rate (2 mm/s at 0.4 m, the base's half width; F12) [rad/s]."""
MIN_REST = 0.5
"""The robot is at rest once it stays so this long (F12) [s]."""


def _period(times: FloatArray) -> float:
    t = np.asarray(times, dtype=np.float64)
    if t.size < 3:
        raise ValueError(f"need at least 3 samples, got {t.size}")
    return float(t[1] - t[0])


def smooth(values: FloatArray, dt: float, width: float = SMOOTHING) -> FloatArray:
    """Centred moving average of ``width`` [s] (an odd number of samples ≥ 1) along axis 0,
    the ends averaged over the samples that exist."""
    x = np.asarray(values, dtype=np.float64)
    half = min(max(0, round(width / dt / 2.0)), (x.shape[0] - 1) // 2)  # no wider than the data
    if half == 0:
        return x.copy()
    kernel = np.ones(2 * half + 1)
    flat = x.reshape(x.shape[0], -1)
    ones = np.convolve(np.ones(x.shape[0]), kernel, mode="same")
    cols = [np.convolve(flat[:, i], kernel, mode="same") / ones for i in range(flat.shape[1])]
    return np.column_stack(cols).reshape(x.shape)


def smoothed_rate(times: FloatArray, values: FloatArray, width: float = SMOOTHING) -> FloatArray:
    """Rate of ``values`` (N or (N, d)) per second: central differences, then :func:`smooth`."""
    dt = _period(times)
    return smooth(np.gradient(np.asarray(values, dtype=np.float64), dt, axis=0), dt, width)


def correlation_lag(times: FloatArray, leader: FloatArray, follower: FloatArray,
                    max_lag: float) -> tuple[float | None, float]:
    """(τ [s], ρ) maximising the normalised cross-correlation of two rate series (F9, as given:
    smooth them first); τ > 0: the follower comes later."""
    dt = _period(times)
    a = np.asarray(leader, dtype=np.float64).reshape(len(times), -1)
    b = np.asarray(follower, dtype=np.float64).reshape(len(times), -1)
    norm_a, norm_b = float(np.sqrt(np.sum(a**2))), float(np.sqrt(np.sum(b**2)))
    if norm_a < 1e-12 or norm_b < 1e-12:
        return None, 0.0
    kmax = min(round(max_lag / dt), a.shape[0] - 2)
    shifts = np.arange(-kmax, kmax + 1)
    rho = np.array([_rho(a, b, int(k)) for k in shifts])
    ties = np.flatnonzero(rho >= rho.max() - 1e-9)  # equal correlations: the smallest shift
    best = int(ties[np.argmin(np.abs(shifts[ties]))])
    tau = float(shifts[best]) * dt
    if 0 < best < len(rho) - 1:  # a peak inside the range: a parabola through its three shifts
        y0, y1, y2 = rho[best - 1], rho[best], rho[best + 1]
        curve = y0 - 2.0 * y1 + y2
        if curve < 0.0:
            tau += 0.5 * (y0 - y2) / curve * dt
    peak = float(rho[best])
    inside = 0 < best < len(rho) - 1
    moves = norm_b >= LAG_MIN_AMPLITUDE * norm_a
    return (float(tau) if peak >= LAG_MIN_CORRELATION and inside and moves else None), peak


def _rho(a: FloatArray, b: FloatArray, k: int) -> float:
    x, y = (a[: a.shape[0] - k], b[k:]) if k >= 0 else (a[-k:], b[: b.shape[0] + k])
    nx, ny = float(np.sqrt(np.sum(x**2))), float(np.sqrt(np.sum(y**2)))
    return float(np.sum(x * y)) / (nx * ny) if nx > 1e-12 and ny > 1e-12 else 0.0


def rate_lag(times: FloatArray, leader: FloatArray, follower: FloatArray, max_lag: float,
             width: float = SMOOTHING) -> tuple[float | None, float]:
    """(τ [s], ρ) of two position series (N or (N, d); unwrap angles first) by their smoothed
    rates (F9)."""
    return correlation_lag(times, smoothed_rate(times, leader, width),
                           smoothed_rate(times, follower, width), max_lag)


def derivative_stats(times: FloatArray, velocity: FloatArray) -> dict[str, list[float]]:
    """Per axis of a velocity series (N, d): ``p99`` / ``max`` of the acceleration |Δv/Δt| and
    ``jerk_p99`` / ``jerk_max`` of |Δa/Δt| (F10) [unit/s², unit/s³]."""
    dt = _period(times)
    v = np.asarray(velocity, dtype=np.float64).reshape(len(times), -1)
    acc = np.diff(v, axis=0) / dt
    jerk = np.diff(acc, axis=0) / dt
    return {"p99": _per_axis(np.percentile(np.abs(acc), 99, axis=0)),
            "max": _per_axis(np.max(np.abs(acc), axis=0)),
            "jerk_p99": _per_axis(np.percentile(np.abs(jerk), 99, axis=0)),
            "jerk_max": _per_axis(np.max(np.abs(jerk), axis=0))}


def _per_axis(values: FloatArray) -> list[float]:
    return [float(v) for v in np.atleast_1d(values)]


def high_pass(times: FloatArray, signal: FloatArray, cutoff: float = FLUCTUATION_CUTOFF
              ) -> FloatArray:
    """The part of ``signal`` above ``cutoff`` [Hz] (F11): the line through its first and last
    samples removed, then an 8th-order Butterworth high-pass run forwards and backwards (zero
    phase; amplitude 0.5 at the cutoff, 0.82 at 1.1×, 0.998 at 1.5×: sharp enough for the
    control-loop oscillations measured at 1.0–1.7 Hz, where a 4th-order skirt lost 4 % at 1.5 Hz,
    while its ringing after a step stays local — a sharp Fourier cut spread it over the whole
    run)."""
    from scipy.signal import butter, sosfiltfilt

    dt = _period(times)
    x = np.asarray(signal, dtype=np.float64)
    nyquist = 0.5 / dt
    if not 0.0 < cutoff < nyquist:
        raise ValueError(f"fluctuation cutoff {cutoff} Hz must lie in (0, {nyquist:g}) Hz")
    x = x - np.linspace(x[0], x[-1], x.size)
    sos = butter(FLUCTUATION_ORDER, cutoff / nyquist, btype="highpass", output="sos")
    pad = min(x.size - 1, round(3.0 / (cutoff * dt)))  # odd extension over 3 cycles of the cutoff
    return np.asarray(sosfiltfilt(sos, x, padlen=pad)) if x.size > 1 else x


def fluctuation(times: FloatArray, signal: FloatArray, cutoff: float = FLUCTUATION_CUTOFF
                ) -> dict[str, float | None]:
    """The part of ``signal`` above ``cutoff`` [Hz] (F11, :func:`high_pass`): ``rms`` and
    ``max`` of its magnitude [signal unit], ``peak_frequency`` [Hz] of the largest peak of its
    power spectral density (Welch, 10 s segments; ``None``: no fluctuation)."""
    from scipy.signal import welch

    dt = _period(times)
    high = high_pass(times, signal, cutoff)
    freqs, spectrum = welch(high, fs=1.0 / dt, nperseg=min(high.size, round(10.0 / dt)))
    above = freqs >= cutoff
    peak = (float(freqs[above][int(np.argmax(spectrum[above]))])
            if above.any() and spectrum[above].max() > 1e-18 else None)
    return {"rms": float(np.sqrt(np.mean(high**2))), "max": float(np.max(np.abs(high))),
            "peak_frequency": peak}


def _runs(mask: FloatArray) -> list[tuple[int, int]]:
    """(start, end) index pairs (end exclusive) of the True stretches of ``mask``."""
    m = np.concatenate([[False], np.asarray(mask, dtype=bool), [False]])
    edges = np.flatnonzero(np.diff(m.astype(np.int8)))
    return [(int(a), int(b)) for a, b in zip(edges[::2], edges[1::2], strict=True)]


def partner_stops(times: FloatArray, partner: FloatArray, min_stop: float = MIN_STOP
                  ) -> list[tuple[int, int]]:
    """(start, end) sample ranges (end exclusive) in which the partner (N, 3: x, y, ψ) stands
    still for at least ``min_stop`` [s] (F12)."""
    dt = _period(times)
    p = np.asarray(partner, dtype=np.float64)
    speed = np.linalg.norm(smoothed_rate(times, p[:, :2]), axis=1)
    rate = np.abs(smoothed_rate(times, np.unwrap(p[:, 2])))
    still = (speed < PARTNER_STILL_SPEED) & (rate < PARTNER_STILL_RATE)
    return [(a, b) for a, b in _runs(still) if (b - a) * dt >= min_stop - 1e-9]


def rest_after_stops(times: FloatArray, partner: FloatArray, twist: FloatArray
                     ) -> dict[str, Any]:
    """Time to rest of the robot base (body twist (N, 3): v_x, v_y [m/s], ω [rad/s]) after each
    stop of the partner (F12): per stop its start [s], length [s] and ``time_to_rest`` [s]
    (``None``: never at rest in it); over all stops ``time_to_rest_max`` (``None`` when a stop
    had none, or no stop), the base's mean and peak planar speed from 1 s into each stop
    (``speed_mean``, ``speed_max`` [m/s])."""
    t = np.asarray(times, dtype=np.float64)
    dt = _period(t)
    v = np.asarray(twist, dtype=np.float64)
    speed = np.linalg.norm(v[:, :2], axis=1)
    at_rest = (speed < REST_SPEED) & (np.abs(v[:, 2]) < REST_RATE)
    stops: list[dict[str, Any]] = []
    late: list[FloatArray] = []
    hold = max(1, round(MIN_REST / dt))
    # rested[k]: at rest at every sample k … k + hold − 1
    rested = np.convolve(at_rest.astype(float), np.ones(hold), mode="full")[hold - 1:] >= hold
    for a, b in partner_stops(t, partner):
        found = np.flatnonzero(rested[a:max(a, b - hold + 1)])
        stops.append({"start": float(t[a]), "length": (b - a) * dt,
                      "time_to_rest": float(found[0]) * dt if found.size else None})
        late.append(speed[min(a + round(1.0 / dt), b):b])
    times_to_rest = [s["time_to_rest"] for s in stops]
    after = np.concatenate(late) if late else np.zeros(0)
    return {
        "stops": stops,
        "time_to_rest_max": (max(times_to_rest) if stops and None not in times_to_rest
                             else None),
        "speed_mean": float(after.mean()) if after.size else None,
        "speed_max": float(after.max()) if after.size else None,
    }


def finite_or_none(value: float | None) -> float | None:
    """``value`` unless it is None or not finite (JSON-safe)."""
    return None if value is None or not math.isfinite(value) else float(value)
