"""Calibration math, tare under a held contact, drift compensation over a long hold, masking."""

from __future__ import annotations

import numpy as np
import pytest

from skin_driver.calibration import CalibrationConfig, PatchCalibrator

GAIN = 0.0005  # N/count (the default)
OFFSET = 1000.0  # count


def _counts(force: np.ndarray, rng: np.random.Generator, *, noise: float = 2.0,
            offsets: np.ndarray | float = OFFSET) -> np.ndarray:
    """The board model: count = offset + force / gain + noise, rounded and clipped."""
    value = offsets + force / GAIN + rng.normal(0.0, noise, force.shape)
    return np.clip(np.rint(value), 0, 65535).astype(np.uint16)


def test_gain_and_offset_per_taxel() -> None:
    gains = np.array([0.001, 0.002, 0.0005, 0.01])
    offsets = np.array([100.0, 200.0, 300.0, 400.0])
    cfg = CalibrationConfig(filter_window=1, tare_frames=0, drift_time_constant=0, stuck_time=0)
    cal = PatchCalibrator(4, cfg, gains, offsets)
    counts = np.array([1100, 700, 300, 350], dtype=np.uint16)
    out = cal.process(counts, 0.0)
    assert out is not None
    # 0.001·1000 = 1 N; 0.002·500 = 1 N; 0 N; 0.01·(−50) = −0.5 N → clamped to 0 (pressing only).
    np.testing.assert_allclose(out, [1.0, 1.0, 0.0, 0.0], atol=1e-12)


def test_moving_average_is_the_papers_window_of_ten() -> None:
    rng = np.random.default_rng(0)
    cfg = CalibrationConfig(tare_frames=0, drift_time_constant=0, stuck_time=0)
    assert cfg.filter_window == 10
    cal = PatchCalibrator(3, cfg)
    counts = rng.integers(2000, 9000, size=(6000, 3)).astype(np.uint16)
    force = GAIN * (counts - OFFSET)
    out = np.array([cal.process(c, k / 500) for k, c in enumerate(counts)])
    kernel = np.ones(10) / 10
    for j in range(3):
        full = np.convolve(force[:, j], kernel, mode="valid")  # frames 9…end
        np.testing.assert_allclose(out[9:, j], full, rtol=1e-9)
        warm = np.cumsum(force[:9, j]) / np.arange(1, 10)  # mean of what has arrived
        np.testing.assert_allclose(out[:9, j], warm, rtol=1e-12)
    cal.reset_filter()
    after = cal.process(counts[0], 100.0)
    np.testing.assert_allclose(after, force[0], rtol=1e-12)


def test_tare_while_a_contact_is_held() -> None:
    """A firm contact held during tare stays visible; a light one is re-learnt on release."""
    rng = np.random.default_rng(1)
    n, rate = 36, 500.0
    # The true zeros differ from the factory offsets by up to ±60 counts (±0.03 N).
    true_offsets = OFFSET + rng.uniform(-60, 60, n)
    cal = PatchCalibrator(n, CalibrationConfig())  # tare 100 frames, tare_max_shift 0.5 N
    firm = np.zeros(n)
    firm[[3, 4, 9, 10]] = 1.5  # N, pressed from before start-up
    light = np.zeros(n)
    light[20] = 0.2  # N, below tare_max_shift: indistinguishable from an offset
    out = None
    for k in range(int(2.0 * rate)):
        out = cal.process(_counts(firm + light, rng, offsets=true_offsets), k / rate)
        if k < 99:
            assert out is None  # nothing is published while taring
    assert out is not None
    assert cal.status().touched_at_tare == 4
    np.testing.assert_allclose(out[[3, 4, 9, 10]], 1.5, atol=0.035)  # factory error ±0.03 N
    others = np.delete(np.arange(n), [3, 4, 9, 10])
    assert np.all(out[others] < 0.005)
    # Release everything for 6 s; then press 1 N on the lightly-touched taxel.
    t0 = 2.0
    for k in range(int(6.0 * rate)):
        out = cal.process(_counts(np.zeros(n), rng, offsets=true_offsets), t0 + k / rate)
    assert out is not None and np.all(out < 0.035)
    press = np.zeros(n)
    press[20] = 1.0
    for k in range(int(0.5 * rate)):
        out = cal.process(_counts(press, rng, offsets=true_offsets), 8.0 + k / rate)
    assert out is not None
    # The baseline came back down to within the drift band (0.03 N) of the true zero.
    assert out[20] == pytest.approx(1.0, abs=0.035)


def _long_hold(drift_time_constant: float) -> dict[str, np.ndarray]:
    """12 min at 50 Hz, 0.01 N/min common-mode drift, 2 N held on two taxels 1 … 11 min."""
    rng = np.random.default_rng(2)
    n, rate = 16, 50.0
    drift_rate = 0.01 / 60.0  # N/s on every taxel (temperature)
    cfg = CalibrationConfig(drift_time_constant=drift_time_constant, drift_band=0.03)
    cal = PatchCalibrator(n, cfg)
    held = [5, 6]
    samples: dict[str, np.ndarray] = {}
    for k in range(int(720 * rate)):
        t = k / rate
        force = np.full(n, drift_rate * t)
        if 60.0 <= t < 660.0:
            force[held] += 2.0
        out = cal.process(_counts(force, rng), t)
        for name, when in (("held_start", 70.0), ("held_end", 655.0), ("released", 715.0)):
            if k == int(when * rate):
                assert out is not None
                samples[name] = out.copy()
    return samples


def test_drift_compensation_keeps_a_ten_minute_contact() -> None:
    s = _long_hold(drift_time_constant=60.0)
    held, free = [5, 6], [0, 1, 2, 3, 4, 7, 8, 9, 10, 11, 12, 13, 14, 15]
    # The contact keeps its 2 N after 10 min: the error is the tracking lag of the common-mode
    # drift, rate · τ = 0.01 N/min · 1 min = 0.01 N.
    np.testing.assert_allclose(s["held_start"][held], 2.0, atol=0.02)
    np.testing.assert_allclose(s["held_end"][held], 2.0, atol=0.02)
    # Untouched taxels stay at zero although every zero moved 0.11 N by 11 min.
    assert np.all(s["held_end"][free] < 0.02)
    # After release the held taxels return to zero (no residue: the drift during the hold
    # was common-mode and followed).
    assert np.all(s["released"] < 0.02)
    # The iCub-style first-order high-pass with the same τ would have decayed the contact to
    # 2 N · exp(−595 s / 60 s) ≈ 1e-4 N at the same instant.
    assert 2.0 * np.exp(-595.0 / 60.0) < 1e-3


def test_without_drift_compensation_the_zero_walks_away() -> None:
    s = _long_hold(drift_time_constant=0.0)
    # Drift accumulated since tare: 0.01 N/min · (655 s / 60) ≈ 0.109 N.
    assert np.all(s["held_end"][[0, 1, 2]] == pytest.approx(0.109, abs=0.01))


def test_high_pass_reference_decays_a_held_contact() -> None:
    """The complaint, reproduced: a plain high-pass (zero tracks everything) loses the hold."""
    rate, tau = 50.0, 60.0
    baseline, x = 0.0, 2.0
    for _ in range(int(600 * rate)):
        baseline += (1 / rate) / tau * (x - baseline)
    assert x - baseline < 1e-3
    # … whereas our calibrator, on the same held signal, keeps it (no drift here).
    cal = PatchCalibrator(4, CalibrationConfig(tare_frames=0, drift_time_constant=tau,
                                               stuck_time=0))
    rng = np.random.default_rng(3)
    out = None
    force = np.array([0.0, 2.0, 0.0, 0.0])
    for k in range(int(600 * rate)):
        out = cal.process(_counts(force, rng), k / rate)
    assert out is not None and out[1] == pytest.approx(2.0, abs=0.005)


def test_untouched_taxel_follows_its_own_drift() -> None:
    rng = np.random.default_rng(4)
    n, rate = 8, 50.0
    cal = PatchCalibrator(n, CalibrationConfig(drift_time_constant=20.0))
    out = None
    for k in range(int(300 * rate)):
        t = k / rate
        force = np.zeros(n)
        force[2] = 0.0005 * t  # one taxel drifts 0.15 N in 5 min, slowly (within the band)
        out = cal.process(_counts(force, rng), t)
    # EMA lag on a ramp: rate · τ = 0.0005 N/s · 20 s = 0.01 N.
    assert out is not None and out[2] == pytest.approx(0.01, abs=0.005)


def test_dead_stuck_and_saturated_taxels() -> None:
    rng = np.random.default_rng(5)
    n, rate = 6, 100.0
    dead = np.array([False, True, False, False, False, False])
    cal = PatchCalibrator(n, CalibrationConfig(tare_frames=10, stuck_time=0.5), dead=dead)
    force = np.array([0.0, 3.0, 0.0, 1.0, 0.0, 0.0])
    out = None
    for k in range(100):
        counts = _counts(force, rng)
        counts[3] = 3000  # frozen channel (no noise) reading 1 N
        counts[4] = 65535 if k >= 50 else counts[4]  # saturated from 0.5 s on
        out = cal.process(counts, k / rate)
    st = cal.status()
    assert out is not None
    assert out[1] == 0.0  # dead in the layout: masked although pressed
    assert out[3] == 0.0 and st.stuck == 1  # frozen for 1 s > stuck_time
    assert st.dead == 2 and st.saturated == 1
    # A saturated taxel reports its full-scale force (a lower bound), not 0: 0.0005·64535 N.
    assert out[4] == pytest.approx(GAIN * (65535 - OFFSET), abs=0.01)
    # The frozen channel comes back as soon as its count moves.
    counts = _counts(force, rng)
    counts[3] = 3001
    out = cal.process(counts, 1.0)
    assert out is not None and out[3] > 0.5 and cal.status().stuck == 0


@pytest.mark.parametrize(
    "kwargs",
    [{"filter_window": 0}, {"default_gain": float("nan")}, {"drift_band": -1.0},
     {"release_time_constant": 0.0}, {"saturation_count": 70000}, {"default_offset": np.inf}],
)
def test_bad_settings_are_refused(kwargs: dict) -> None:
    with pytest.raises(ValueError, match=next(iter(kwargs))):
        CalibrationConfig(**kwargs)


def test_wrong_frame_size_is_refused() -> None:
    cal = PatchCalibrator(4, CalibrationConfig())
    with pytest.raises(ValueError, match="expected 4 taxels"):
        cal.process(np.zeros(5, np.uint16), 0.0)


@pytest.mark.parametrize(
    ("setting", "value", "allowed"),
    [("filter_window", 0, r"\[1, 1000\]"), ("tare_max_shift", -0.1, r"\[0, inf\]"),
     ("min_free_fraction", float("nan"), r"\[0, 1\]")],
)
def test_setting_refusal_names_the_setting_value_and_range(
    setting: str, value: float, allowed: str
) -> None:
    with pytest.raises(ValueError, match=rf"{setting} refused value {value!r}: allowed {allowed}"):
        CalibrationConfig(**{setting: value})
