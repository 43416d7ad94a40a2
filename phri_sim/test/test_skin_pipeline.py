"""The skin driver's 500 Hz moving average as the realistic plant models it
(phri_sim.world.skin_pipeline), against the driver's own filter."""

from __future__ import annotations

import numpy as np
import pytest

from phri_sim.world.skin_pipeline import (
    DRIVER_RATE_HZ,
    DRIVER_WINDOW,
    FRAME_AGE,
    DriverPipeline,
    pipeline_weights,
)


def test_at_the_driver_rate_it_is_the_drivers_moving_average_of_ten() -> None:
    np.testing.assert_allclose(pipeline_weights(0.002, age=0.0), np.full(10, 0.1))


def test_the_weights_sum_to_one_and_delay_by_the_drivers_window_centre() -> None:
    """Any sampling period: the weighted sample time lies age + (W − 1)/2 frames back (10 ms),
    as the 500 Hz average's does."""
    centre = FRAME_AGE + 0.5 * (DRIVER_WINDOW - 1) / DRIVER_RATE_HZ
    for period in (0.002, 0.005, 0.01):
        w = pipeline_weights(period)
        assert w.sum() == pytest.approx(1.0)
        assert float(np.sum(w * np.arange(w.size) * period)) == pytest.approx(centre)
    np.testing.assert_allclose(pipeline_weights(0.01), [0.25, 0.5, 0.25])


def test_a_force_linear_in_time_reads_as_the_500_hz_average_would() -> None:
    """A press rising at 40 N/s, sampled every 10 ms: the pipeline's output equals the mean of
    the ten 500 Hz frames 1, 3, …, 19 ms old."""
    pipeline = DriverPipeline(0.01, ("a",))
    rate = 40.0
    out = 0.0
    for k in range(1, 20):
        out = float(pipeline.push({"a": np.array([rate * 0.01 * k])})["a"][0])
    t = 0.01 * 19
    frames = [rate * (t - FRAME_AGE - m / DRIVER_RATE_HZ) for m in range(DRIVER_WINDOW)]
    assert out == pytest.approx(float(np.mean(frames)))


def test_a_released_patch_is_held_until_its_window_has_passed() -> None:
    """A settled 10 N hold (primed) released at one sample: the readings fall 10 → 7.5 → 2.5
    → 0 and :meth:`holding` says when a patch must still be read."""
    pipeline = DriverPipeline(0.01, ("a", "b"))
    pipeline.prime({"a": np.array([10.0])})
    assert pipeline.holding("a") and not pipeline.holding("b")
    readings = [float(pipeline.push({"a": np.zeros(1)})["a"][0]) for _ in range(3)]
    assert readings == pytest.approx([7.5, 2.5, 0.0])
    assert not pipeline.holding("a")
    assert pipeline.push({}) == {}  # patches not sampled: nothing read, nothing returned


def test_bad_periods_are_refused() -> None:
    with pytest.raises(ValueError, match="sample period"):
        pipeline_weights(0.0)
    with pytest.raises(ValueError, match="window"):
        pipeline_weights(0.01, window=0)
