"""The periodic control thread: absolute deadlines, skipped deadlines counted, errors stop it."""

from __future__ import annotations

import math
import threading
import time

import pytest
from hypothesis import given
from hypothesis import strategies as st

from phri_common.periodic import PeriodicThread, next_deadline


@given(deadline=st.floats(-1e3, 1e3), late=st.floats(-1.0, 10.0),
       period=st.floats(1e-4, 1.0))
def test_next_deadline_is_the_first_grid_point_after_now(deadline: float, late: float,
                                                         period: float) -> None:
    now = deadline + late
    following, skipped = next_deadline(deadline, now, period)
    steps = (following - deadline) / period
    # On the grid, one step plus the skipped ones, after now, and the step before was not.
    assert math.isclose(steps, 1 + skipped, rel_tol=1e-6, abs_tol=1e-6)
    assert skipped >= 0
    if skipped == 0:
        assert math.isclose(following, deadline + period, rel_tol=1e-12, abs_tol=1e-12)
    else:
        assert following > now - 1e-9 * max(1.0, abs(now))
        assert following - period <= now + 1e-9 * max(1.0, abs(now))


def test_next_deadline_analytic_cases() -> None:
    assert next_deadline(1.0, 1.0005, 0.002) == (1.002, 0)  # on time
    following, skipped = next_deadline(1.0, 1.0071, 0.002)  # 1.002, 1.004, 1.006 passed
    assert skipped == 3 and math.isclose(following, 1.008)
    with pytest.raises(ValueError, match="period"):
        next_deadline(0.0, 0.0, 0.0)


class FakeTime:
    """A clock that only moves when the loop sleeps or a cycle takes time."""

    def __init__(self) -> None:
        self.now = 100.0
        self.sleeps: list[float] = []

    def clock(self) -> float:
        return self.now

    def sleep(self, seconds: float) -> None:
        self.sleeps.append(seconds)
        self.now += seconds


def run_cycles(loop: PeriodicThread, cycles: int, timeout: float = 60.0) -> None:
    """Run ``loop`` (on a fake clock: it never really sleeps) until it has run ``cycles``
    cycles or ended; ``timeout`` [s] only bounds the wait on a stalled machine."""
    loop.start()
    deadline = time.monotonic() + timeout
    while loop.running and loop.cycles < cycles and time.monotonic() < deadline:
        time.sleep(0.001)
    loop.stop()


def test_cycles_run_at_absolute_deadlines_and_overruns_are_skipped() -> None:
    fake = FakeTime()
    starts: list[float] = []
    slow = {3}  # the 4th cycle takes 2.5 periods

    def cycle() -> None:
        starts.append(fake.now)
        if len(starts) - 1 in slow:
            fake.now += 0.005
        else:
            fake.now += 0.0003

    loop = PeriodicThread(0.002, cycle, lambda err: None, clock=fake.clock, sleep=fake.sleep)
    run_cycles(loop, 8)
    offsets = [round((t - 100.0) / 0.002, 6) for t in starts[:8]]
    # 1, 2, 3, 4 on time; the 4th ends at 4 + 0.0003/0.002 + 2.5 → 5 and 6 skipped, then 7, 8 …
    assert offsets == [1.0, 2.0, 3.0, 4.0, 7.0, 8.0, 9.0, 10.0]
    assert loop.overruns == 2
    assert loop.error is None


def test_an_error_in_a_cycle_reaches_on_error_and_ends_the_loop() -> None:
    errors: list[BaseException] = []
    calls = [0]

    def cycle() -> None:
        calls[0] += 1
        if calls[0] == 3:
            raise RuntimeError("boom")

    fake = FakeTime()
    loop = PeriodicThread(0.002, cycle, errors.append, clock=fake.clock, sleep=fake.sleep)
    run_cycles(loop, 100)
    assert calls[0] == 3 and loop.cycles == 2
    assert len(errors) == 1 and isinstance(loop.error, RuntimeError)
    assert not loop.running


def test_stop_ends_a_real_time_loop() -> None:
    """On the real clock and sleep: the loop runs, and stop() ends its thread (the waits only
    bound a stalled machine; how soon is the fake-clock test below)."""
    ran = threading.Event()
    loop = PeriodicThread(0.002, ran.set, lambda err: None)
    loop.start()
    assert ran.wait(60.0)
    assert loop.stop(timeout=60.0) and not loop.running
    assert loop.cycles > 0


def test_a_stop_during_a_cycle_or_a_sleep_ends_the_loop_before_another_cycle() -> None:
    """stop() asked for while a cycle runs: that cycle is the last; asked for while the loop
    sleeps to its deadline: no cycle runs after the sleep."""
    fake = FakeTime()
    calls = [0]
    during_cycle: PeriodicThread

    def cycle() -> None:
        calls[0] += 1
        if calls[0] == 3:
            during_cycle.stop()

    during_cycle = PeriodicThread(0.002, cycle, lambda err: None, clock=fake.clock,
                                  sleep=fake.sleep)
    run_cycles(during_cycle, 100)
    assert calls[0] == 3 and during_cycle.cycles == 3 and not during_cycle.running

    fake = FakeTime()
    calls[0] = 0
    during_sleep: PeriodicThread

    def sleep(seconds: float) -> None:
        fake.sleep(seconds)
        if len(fake.sleeps) == 3:
            during_sleep.stop()

    during_sleep = PeriodicThread(0.002, lambda: calls.__setitem__(0, calls[0] + 1),
                                  lambda err: None, clock=fake.clock, sleep=sleep)
    run_cycles(during_sleep, 100)
    assert calls[0] == 2 and during_sleep.cycles == 2 and not during_sleep.running


def test_bad_period_is_refused_naming_it() -> None:
    with pytest.raises(ValueError, match="period must be > 0 s, got -1"):
        PeriodicThread(-1.0, lambda: None, lambda err: None)


def test_a_refused_priority_is_reported_and_the_loop_still_runs() -> None:
    def refuse(priority: int) -> None:
        raise PermissionError(1, "Operation not permitted")

    asked: list[int] = []
    ran = threading.Event()
    refused = PeriodicThread(0.002, ran.set, lambda err: None, priority=40, set_priority=refuse)
    refused.start()
    assert ran.wait(60.0)  # the priority is settled before the first cycle
    assert refused.priority_error is not None and "priority 40 refused" in refused.priority_error
    assert refused.stop(timeout=60.0)
    granted = PeriodicThread(0.002, lambda: None, lambda err: None, priority=10,
                             set_priority=asked.append)
    granted.start()
    assert granted.stop(timeout=60.0)  # the thread asks for its priority before anything else
    assert asked == [10] and granted.priority_error is None
    normal = PeriodicThread(0.002, lambda: None, lambda err: None, set_priority=asked.append)
    normal.start()
    assert normal.stop(timeout=60.0)
    assert asked == [10]  # priority 0: the scheduler is left alone
    with pytest.raises(ValueError, match=r"priority must be in \[0, 99\], got 100"):
        PeriodicThread(0.002, lambda: None, lambda err: None, priority=100)
