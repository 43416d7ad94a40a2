"""Board clock → node clock mapping: stamps follow the board's own time base."""

from __future__ import annotations

import numpy as np
import pytest

from skin_driver.board_clock import BOARD_CLOCK_MODULO_US, BoardClock

PERIOD_US = 2000  # 500 Hz
T0_NS = 1_700_000_000_000_000_000  # some wall-clock time [ns]


def _arrivals(n: int, seed: int, min_delay_ns: int = 300_000) -> tuple[np.ndarray, np.ndarray]:
    """Board times [µs] and arrival times [ns] with a random transfer delay ≥ min_delay."""
    rng = np.random.default_rng(seed)
    board_us = np.arange(n) * PERIOD_US + 5_000_000
    delay = min_delay_ns + rng.exponential(400_000, n).astype(np.int64)
    return board_us, T0_NS + board_us * 1000 + delay


def test_stamps_keep_the_board_spacing_under_arrival_jitter() -> None:
    board_us, arrival = _arrivals(2000, seed=1)
    clock = BoardClock()
    stamps = np.array([clock.stamp(int(b), int(a)) for b, a in zip(board_us, arrival, strict=True)])
    assert np.all(stamps <= arrival)  # never later than the bytes arrived
    steady = np.diff(stamps[500:])
    # The arrival spacing jitters by hundreds of µs; the stamps keep 2 ms within the drift leak.
    assert np.diff(arrival[500:]).std() > 100_000
    assert np.abs(steady - PERIOD_US * 1000).max() <= 100_000  # 0.1 ms vs ~0.4 ms jitter
    # And they sit near the true sampling time plus the least delay (300 µs).
    err = stamps[500:] - (T0_NS + board_us[500:] * 1000)
    assert np.all((err >= 299_000) & (err <= 600_000))


def test_a_burst_after_a_stall_gets_one_stamp_per_frame() -> None:
    # A stalled read: frames 300…499 (0.4 s of samples) arrive in one chunk, 50 ms after the
    # last of them was sampled: the same arrival time for all 200.
    board_us, arrival = _arrivals(600, seed=2)
    arrival[300:500] = arrival[499] + 50_000_000
    clock = BoardClock()
    stamps = [clock.stamp(int(b), int(a)) for b, a in zip(board_us, arrival, strict=True)]
    burst = np.array(stamps[300:500])
    assert len(set(burst.tolist())) == 200
    np.testing.assert_allclose(np.diff(burst), PERIOD_US * 1000, atol=5_000)
    true = T0_NS + board_us[300:500] * 1000
    assert np.all(np.abs(burst - true) < 2_000_000)  # within 2 ms of sampling, not 0.45 s


def test_board_clock_wrap_is_continuous() -> None:
    clock = BoardClock()
    start = BOARD_CLOCK_MODULO_US - 10 * PERIOD_US
    stamps = []
    for k in range(20):
        board = (start + k * PERIOD_US) % BOARD_CLOCK_MODULO_US
        stamps.append(clock.stamp(board, T0_NS + k * PERIOD_US * 1000 + 500_000))
    np.testing.assert_array_equal(np.diff(stamps), PERIOD_US * 1000)
    assert clock.restarts == 0


def test_board_reset_and_jump_restart_the_mapping() -> None:
    clock = BoardClock()
    for k in range(10):
        clock.stamp(1_000_000 + k * PERIOD_US, T0_NS + k * 2_000_000)
    # The board restarts: its clock goes back to zero while the host time goes on.
    arrival = T0_NS + 10 * 2_000_000
    assert clock.stamp(0, arrival) == arrival
    assert clock.stamp(PERIOD_US, arrival + 2_000_000) == arrival + 2_000_000
    assert clock.restarts == 1
    # A forward jump of the board clock (5 s) lowers the offset at once: stamp = arrival.
    b = 2 * PERIOD_US + 5_000_000
    assert clock.stamp(b, arrival + 4_000_000) == arrival + 4_000_000
    assert clock.restarts == 1
    # A board clock that stands still while frames keep arriving for 2 s: re-anchored.
    assert clock.stamp(b, arrival + 2_004_000_000) == arrival + 2_004_000_000
    assert clock.restarts == 2


def test_slow_board_clock_is_followed() -> None:
    # The board clock runs 200 ppm slow: a − b grows 200 µs per second; the offset must follow.
    clock = BoardClock()
    last_err = 0
    for k in range(5 * 500):  # 5 s
        b = k * PERIOD_US
        a = T0_NS + int(k * PERIOD_US * 1000 * (1 + 200e-6)) + 300_000
        s = clock.stamp(b, a)
        last_err = a - s
    assert 0 <= last_err < 400_000  # stays near the least delay, not 1 ms behind


@pytest.mark.parametrize(("kwargs", "name"), [({"drift_rate": -1.0}, "drift_rate"),
                                              ({"reanchor_after": 0.0}, "reanchor_after")])
def test_bad_settings_are_refused(kwargs: dict, name: str) -> None:
    with pytest.raises(ValueError, match=name):
        BoardClock(**kwargs)
