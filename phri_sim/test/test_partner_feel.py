"""What the partner feels (phri_sim.evaluation.partner_feel) and the bars built on it, each
against a case with a known answer."""

from __future__ import annotations

import math

import numpy as np
import pytest

from phri_sim.evaluation.following_metrics import (
    TEMPO_BARS,
    WALTZ_BARS,
    FollowingSeries,
    check_bars,
    following_summary,
)
from phri_sim.evaluation.partner_feel import (
    REST_SPEED,
    derivative_stats,
    fluctuation,
    partner_stops,
    rate_lag,
    rest_after_stops,
    smooth,
)

DT = 0.01
T = np.arange(0.0, 40.0, DT)


def _turning_partner() -> np.ndarray:
    """A partner who stands 1 s, turns 90° in 10 s (smooth), stands, turns back: (x, y, ψ)."""
    def s(t: np.ndarray, t0: float, length: float) -> np.ndarray:
        u = np.clip((t - t0) / length, 0.0, 1.0)
        return u - np.sin(2.0 * math.pi * u) / (2.0 * math.pi)

    yaw = 0.5 * math.pi * (s(T, 1.0, 10.0) - s(T, 20.0, 10.0))
    return np.column_stack([np.zeros_like(T), np.zeros_like(T), yaw])


def _delayed(values: np.ndarray, delay: float) -> np.ndarray:
    """``values`` (N, 3) shifted later by ``delay`` [s] (held at the start)."""
    k = round(delay / DT)
    return np.vstack([np.repeat(values[:1], k, axis=0), values[: values.shape[0] - k]])


def test_a_robot_that_copies_the_partners_yaw_rate_03_s_later_lags_03_s() -> None:
    partner = _turning_partner()
    robot = _delayed(partner, 0.3)
    tau, rho = rate_lag(T, np.unwrap(partner[:, 2]), np.unwrap(robot[:, 2]), max_lag=3.0)
    assert tau == pytest.approx(0.3, abs=0.002)
    assert rho > 0.99


def test_smoothing_does_not_shift_and_averages_ripple_away() -> None:
    """A centred average: a ramp stays a ramp; a period-to-period alternation of ±1 averages to
    about 1/21 (21 samples in 0.2 s)."""
    ramp = 0.1 * T
    np.testing.assert_allclose(smooth(ramp, DT)[20:-20], ramp[20:-20], atol=1e-12)
    ripple = np.where(np.arange(T.size) % 2 == 0, 1.0, -1.0)
    assert np.max(np.abs(smooth(ripple, DT)[20:-20])) == pytest.approx(1.0 / 21.0)


def test_a_sinusoid_of_known_amplitude_has_the_known_fluctuation_rms() -> None:
    """10 N + 0.8 N at 1.5 Hz + a slow 3 N swell at 0.1 Hz: above 1 Hz the RMS is 0.8/√2 N, the
    peak at 1.5 Hz; the swell does not count."""
    force = 10.0 + 0.8 * np.sin(2.0 * math.pi * 1.5 * T) + 3.0 * np.sin(2.0 * math.pi * 0.1 * T)
    out = fluctuation(T, force)
    assert out["rms"] == pytest.approx(0.8 / math.sqrt(2.0), rel=0.01)
    assert out["max"] == pytest.approx(0.8, rel=0.02)
    assert out["peak_frequency"] == pytest.approx(1.5, abs=0.1)
    assert fluctuation(T, np.full(T.size, 10.0))["rms"] == pytest.approx(0.0, abs=1e-9)


def test_accelerations_and_jerks_of_known_ramps() -> None:
    """v_x ramps at 0.5 m/s² for 2 s then stops in one period (a step of 1 m/s² · 1 s / DT of
    jerk); ω ramps at 1.2 rad/s² throughout."""
    vx = np.clip(0.5 * T, 0.0, 1.0)
    vx[T >= 5.0] = 0.0
    v = np.column_stack([vx, np.zeros_like(T), 1.2 * T])
    out = derivative_stats(T, v)
    assert out["max"][0] == pytest.approx(1.0 / DT)  # the stop: 1 m/s in one period
    assert out["p99"][0] == pytest.approx(0.5, abs=1e-9)
    assert out["max"][2] == pytest.approx(1.2) and out["p99"][2] == pytest.approx(1.2)
    assert out["jerk_max"][2] == pytest.approx(0.0, abs=1e-6)
    assert out["jerk_max"][0] == pytest.approx(1.0 / DT**2)


def test_time_to_rest_of_a_robot_that_coasts_down_exponentially() -> None:
    """The partner's turn ends at 11 s: still from about 10.2 s (its smoothed yaw rate below
    0.02 rad/s) until the next turn has begun (about 20.8 s). The robot turns on at 0.1 rad/s
    when the partner stops and coasts down with τ = 0.4 s: at rest (< 0.005 rad/s, for 0.5 s)
    τ·ln(0.1/0.005) = 1.20 s after the stop. The 1 s stand before the first turn is too short
    to be a stop."""
    partner = _turning_partner()
    stops = partner_stops(T, partner)
    assert 10.0 < T[stops[0][0]] < 11.0 and 20.0 < T[stops[0][1]] < 21.0
    t_stop = T[stops[0][0]]
    twist = np.zeros((T.size, 3))
    after = (t_stop <= T) & (T < 20.0)
    twist[after, 2] = 0.1 * np.exp(-(T[after] - t_stop) / 0.4)
    out = rest_after_stops(T, partner, twist)
    first = out["stops"][0]
    assert first["start"] == pytest.approx(t_stop)
    assert first["time_to_rest"] == pytest.approx(0.4 * math.log(0.1 / 0.005), abs=DT)
    assert out["time_to_rest_max"] == first["time_to_rest"]


def test_a_robot_that_never_comes_to_rest_has_no_time_to_rest() -> None:
    partner = _turning_partner()
    twist = np.zeros((T.size, 3))
    twist[:, 0] = 2.0 * REST_SPEED * np.sin(2.0 * math.pi * T)  # ±4 mm/s forever
    out = rest_after_stops(T, partner, twist)
    assert out["stops"] and out["time_to_rest_max"] is None
    assert out["speed_max"] == pytest.approx(2.0 * REST_SPEED, rel=0.01)


def _series(base: np.ndarray, twist: np.ndarray, command: np.ndarray) -> FollowingSeries:
    partner = _turning_partner()
    partner[:, :2] = [0.6, 0.0]
    force = np.full(T.size, 10.0)
    return FollowingSeries(T, base, partner, force, force > 0.0, twist=twist, command=command)


def test_a_robot_that_does_nothing_fails_the_waltz_bars() -> None:
    """The motionless robot: heading drift 90°, no turning lag (it does not turn) — both
    missed; it is at rest in every stop."""
    still = np.zeros((T.size, 3))
    out = following_summary(_series(still, still, still), 10.0, WALTZ_BARS)
    assert out["turning_lag"] is None
    assert out["pass"]["turning_lag"] is False
    assert out["pass"]["heading_drift"] is False
    assert out["pass"]["rest_time"] is True
    assert out["pass"]["all"] is False


def test_a_robot_that_turns_with_the_partner_passes_the_waltz_bars() -> None:
    """The robot turns with the partner about the partner's centre 0.1 s later, commanding
    what it does: every bar met (force steady at 10 N)."""
    partner = _turning_partner()
    yaw = _delayed(partner, 0.1)[:, 2]
    base = np.column_stack([0.6 - 0.6 * np.cos(yaw), -0.6 * np.sin(yaw), yaw])
    rate = np.gradient(yaw, DT)
    twist = np.column_stack([np.zeros_like(T), -0.6 * rate, rate])
    out = following_summary(_series(base, twist, twist), 10.0, WALTZ_BARS,
                            {"person": {"person_waist": 12.0}, "robot": {}})
    assert out["turning_lag"] == pytest.approx(0.1, abs=0.005)
    assert out["pass"]["all"] is True, out["pass"]


def test_commanded_acceleration_above_the_rated_fails_its_bar() -> None:
    still = np.zeros((T.size, 3))
    jumpy = still.copy()
    jumpy[::2, 1] = 0.02  # ±0.02 m/s every period: 2 m/s²
    out = following_summary(_series(still, still, jumpy), 10.0, WALTZ_BARS)
    assert out["base_acceleration"]["commanded"]["p99"][1] == pytest.approx(2.0)
    assert out["pass"]["command_acceleration"] is False


def test_bars_that_do_not_apply_are_neither_met_nor_missed() -> None:
    """No turn of the partner: the turning-lag bar is n/a (None); the tempo bars carry no band
    and no turning lag at all, but the held share."""
    partner = _turning_partner()
    partner[:, 2] = 0.0
    series = FollowingSeries(T, np.zeros((T.size, 3)), partner, np.full(T.size, 10.0),
                             np.ones(T.size, bool))
    out = following_summary(series, 10.0, WALTZ_BARS)
    assert out["pass"]["turning_lag"] is None
    tempo = check_bars(out, TEMPO_BARS)
    assert "band_share" not in tempo and "turning_lag" not in tempo
    assert tempo["held_share"] is True
