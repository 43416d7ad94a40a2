"""The skin-alone plausibility checks (contact_estimation.plausibility) on synthetic frames:
a dead region is refused and a frozen-but-noisy contact reported still, a live skin is
neither, each verdict clears when the statistics are plausible again, and a still hold is never
refused."""

from __future__ import annotations

import numpy as np
import pytest

from contact_estimation.plausibility import (
    DeadRegionDetector,
    FrozenDetector,
    PlausibilityConfig,
    SkinImplausible,
)

N = 400
PERIOD_NS = 10_000_000
"""100 Hz frames."""


def live_frame(rng: np.random.Generator, load: float = 0.0) -> np.ndarray:
    """A live patch: clipped noise of 5 mN on every taxel (about half read 0 in a frame), and
    ``load`` [N] on the first 20 taxels."""
    forces = np.maximum(rng.normal(0.0, 0.005, N), 0.0)
    forces[:20] += load / 20
    return forces


def test_a_live_patch_is_not_a_dead_region() -> None:
    rng = np.random.default_rng(1)
    dead = DeadRegionDetector(PlausibilityConfig())
    for k in range(500):  # 5 s, touched and not
        dead.check("p", live_frame(rng, 10.0 if k % 200 < 100 else 0.0), k * PERIOD_NS)
    assert dead.silent["p"] < 0.01 * N


@pytest.mark.parametrize("silent_share", [0.5, 1.0])
def test_a_silent_region_is_refused_after_dead_time_and_clears_with_noise(
        silent_share: float) -> None:
    """Half the patch (skin_half_dead) or all of it (a cut cable, skin_blind) reading 0 N."""
    rng = np.random.default_rng(2)
    dead = DeadRegionDetector(PlausibilityConfig(dead_time=1.0, max_dead_fraction=0.25))
    k = 0
    for k in range(100):
        dead.check("p", live_frame(rng, 10.0), k * PERIOD_NS)
    cut = int(silent_share * N)
    with pytest.raises(SkinImplausible, match="dead region") as err:
        for k in range(100, 260):  # silent from 1.00 s on; a verdict at the latest at 2.0 s
            frame = live_frame(rng, 10.0)
            frame[:cut] = 0.0
            dead.check("p", frame, k * PERIOD_NS)
    assert err.value.kind == "dead_region" and k <= 200
    # Noise again: each live frame changes about half the silent taxels (the rest read 0 again),
    # so the verdict clears within a few frames.
    for j in range(1, 10):
        try:
            dead.check("p", live_frame(rng, 10.0), (k + j) * PERIOD_NS)
            break
        except SkinImplausible:
            continue
    assert j <= 4 and dead.silent["p"] <= 0.25 * N


def contact(rng: np.random.Generator, t: float, frozen: bool) -> tuple[float, tuple]:
    """Force [N] and centre [m] of a held waist: a live hold varies with the dance (≈ ±10 %),
    a frozen one only by 0.5 % noise of its taxels (≈ 0.1 % of the total)."""
    if frozen:
        return 10.0 * (1.0 + 0.001 * rng.standard_normal()), (0.1 + 1e-5 * rng.standard_normal(),
                                                              0.0, 0.05)
    return 10.0 + np.sin(2.0 * t) + 0.02 * rng.standard_normal(), (
        0.1 + 0.003 * np.sin(0.7 * t), 0.0, 0.05)


def test_a_frozen_contact_is_reported_still_within_two_windows_a_live_one_never() -> None:
    """Reported, not refused: the controller judges a still skin against the joints."""
    rng = np.random.default_rng(3)
    frozen = FrozenDetector(PlausibilityConfig(frozen_window=2.0))
    for k in range(1000):  # 10 s of a live hold
        force, center = contact(rng, k * 0.01, False)
        assert frozen.check("p", force, center, True, k * PERIOD_NS) == ""
    caught = None
    for k in range(1000, 1500):
        force, center = contact(rng, k * 0.01, True)
        why = frozen.check("p", force, center, True, k * PERIOD_NS)
        if why:
            assert "plausibility_frozen_window" in why and why == frozen.frozen["p"]
            caught = k
            break
    assert caught is not None and (caught - 1000) * 0.01 <= 4.0 + 1e-9
    assert frozen.check("p", 0.0, (0.0, 0.0, 0.0), False, (caught + 1) * PERIOD_NS) == ""
    assert frozen.check("p", 10.0, (0.1, 0.0, 0.05), True, (caught + 2) * PERIOD_NS) == ""


def test_checks_switched_off_and_refused_settings() -> None:
    off = PlausibilityConfig(dead_time=0.0, frozen_window=0.0)
    dead, frozen = DeadRegionDetector(off), FrozenDetector(off)
    for k in range(500):
        dead.check("p", np.zeros(N), k * PERIOD_NS)
        frozen.check("p", 10.0, (0.1, 0.0, 0.0), True, k * PERIOD_NS)
    with pytest.raises(ValueError, match="max_dead_fraction"):
        PlausibilityConfig(max_dead_fraction=2.0)


def test_a_still_steady_hold_of_60_s_is_not_refused_but_reported_still() -> None:
    """A partner holding still on a well-followed link: the true contact constant, the reading
    varying only by the skin's own noise (5 mN on each of 20 loaded taxels: ≈ 0.2 % of 10 N).
    Stillness alone is no evidence of a frozen skin (the robot's and partner's joints are the
    judge: the controller's skin-against-joints check), so no frame is refused; the stillness
    is reported (diagnostics WARN)."""
    rng = np.random.default_rng(5)
    frozen = FrozenDetector(PlausibilityConfig(frozen_window=2.0))
    for k in range(6000):  # 60 s at 100 Hz
        force = 10.0 + 0.005 * np.sqrt(20) * rng.standard_normal()
        frozen.check("p", force, (0.1 + 1e-5 * rng.standard_normal(), 0.0, 0.05), True,
                     k * PERIOD_NS)
    assert "stayed within" in frozen.frozen["p"]
