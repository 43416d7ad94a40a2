"""The skin sensor model (eq. S1 of phri_sim.world.skin_sensor): quantisation, gain error, offset,
noise, dead taxels, saturation, seeding. Expected values are worked out from the model's
definition (G = 0.5 mN per count, zero at 1000 counts), not taken from the code."""

from __future__ import annotations

import numpy as np
import pytest

from phri_sim.world.skin_sensor import PatchSensor, SensorConfig
from skin_driver.layout import rectangular_patch

N = 4000
LAYOUT = rectangular_patch("test_patch", "test_link", 64, 64)
IDEAL = SensorConfig(noise_std=0.0, gain_error_std=0.0, offset_std=0.0, dead_taxels=0)


def _sensor(config: SensorConfig, seed: int = 0, board: int = 0) -> PatchSensor:
    return PatchSensor(LAYOUT, config, seed, board)


def test_layout_is_large_enough_for_statistics() -> None:
    assert LAYOUT.size >= N


def test_ideal_board_quantises_with_half_a_millinewton_per_count() -> None:
    s = _sensor(IDEAL)
    forces = np.zeros(LAYOUT.size)
    forces[:4] = [0.0, 0.01, 0.00026, 1.0]  # 0, 20, 0.52 → 1, 2000 counts above the zero
    c = s.counts(forces, 0.0)
    assert c.dtype == np.uint16
    np.testing.assert_array_equal(c[:4], [1000, 1020, 1001, 3000])
    np.testing.assert_allclose(s.reading(c)[:4], [0.0, 0.01, 0.0005, 1.0], atol=1e-12)


def test_saturation_and_floor_of_the_adc() -> None:
    s = _sensor(IDEAL)
    forces = np.zeros(LAYOUT.size)
    forces[0] = 100.0  # 1000 + 200,000 counts: beyond 16 bits
    assert s.counts(forces, 0.0)[0] == 65535


def test_gain_error_spread_matches_the_setting() -> None:
    s = _sensor(SensorConfig(noise_std=0.0, gain_error_std=0.05, offset_std=0.0,
                             dead_taxels=0), seed=3)
    forces = np.full(LAYOUT.size, 2.0)  # 4000 counts: quantisation ≪ 5 %
    ratio = s.reading(s.counts(forces, 0.0)) / forces
    assert np.mean(ratio) == pytest.approx(1.0, abs=0.005)
    assert np.std(ratio) == pytest.approx(0.05, rel=0.1)


def test_offset_is_in_the_counts_and_a_perfect_tare_removes_it() -> None:
    s = _sensor(SensorConfig(noise_std=0.0, gain_error_std=0.0, offset_std=20.0,
                             dead_taxels=0), seed=4)
    c = s.counts(np.zeros(LAYOUT.size), 0.0).astype(float)
    assert np.std(c) == pytest.approx(20.0, rel=0.1)
    assert np.mean(c) == pytest.approx(1000.0, abs=2.0)
    assert np.max(s.reading(c.astype(np.uint16))) <= 0.5 * 0.0005 + 1e-12  # half a count


def test_noise_is_independent_per_sample_with_the_set_deviation() -> None:
    s = _sensor(SensorConfig(noise_std=0.005, gain_error_std=0.0, offset_std=0.0,
                             dead_taxels=0), seed=5)
    zeros = np.zeros(LAYOUT.size)
    a = s.counts(zeros, 0.0).astype(float) - 1000.0
    b = s.counts(zeros, 0.002).astype(float) - 1000.0
    assert np.std(a) == pytest.approx(10.0, rel=0.1)  # 0.005 N / 0.5 mN per count
    assert abs(np.corrcoef(a, b)[0, 1]) < 0.1


def test_dead_taxels_never_respond() -> None:
    s = _sensor(SensorConfig(noise_std=0.0, gain_error_std=0.0, offset_std=0.0,
                             dead_taxels=3), seed=6)
    pressed = s.counts(np.full(LAYOUT.size, 1.0), 0.0)
    idle = s.counts(np.zeros(LAYOUT.size), 0.0)
    unchanged = np.flatnonzero(pressed == idle)
    assert unchanged.size == 3
    np.testing.assert_array_equal(np.flatnonzero(s.dead), unchanged)


def test_same_seed_same_board_other_board_other_constants() -> None:
    config = SensorConfig()
    forces = np.full(LAYOUT.size, 0.3)
    a, b = _sensor(config, 7, 1), _sensor(config, 7, 1)
    np.testing.assert_array_equal(a.counts(forces, 0.0), b.counts(forces, 0.0))
    other = _sensor(config, 7, 2)
    assert not np.array_equal(a.zero, other.zero)
    a.reset_noise()
    b.reset_noise()
    np.testing.assert_array_equal(a.frame(forces, 0.0), b.frame(forces, 0.0))


@pytest.mark.parametrize(("field", "value"), [("noise_std", -1.0), ("gain_error_std", 0.9),
                                              ("offset_std", float("nan")),
                                              ("dead_taxels", -1)])
def test_bad_setting_is_refused_by_name(field: str, value: float) -> None:
    with pytest.raises(ValueError, match=field):
        SensorConfig(**{field: value})
