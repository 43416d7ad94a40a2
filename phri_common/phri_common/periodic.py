"""A control loop in its own thread, woken at absolute deadlines (no ROS).

Why not an executor timer: with rclpy 9.1's events executor every timer tick and every input
message is one event — a C++ → Python round trip with two thread wake-ups — and at 500 Hz with
five inputs those events alone cost a large share of a core before any work (docs/benchmarks.md,
"Controller node"). A loop that sleeps to its next deadline and reads its inputs itself
(:mod:`phri_common.polled`) wakes once per period, as ros2_control's update loop does.

Deadlines are absolute (``start + k·period``), so lateness does not accumulate; a cycle that
overruns one or more deadlines skips them (counted in :attr:`PeriodicThread.overruns`) instead of
running a burst of late cycles back to back.
"""

from __future__ import annotations

import os
import threading
import time
from collections.abc import Callable

PRIORITY_RANGE = (0, 99)
"""``priority`` of :class:`PeriodicThread`: 0 = the normal scheduler; 1–99 = SCHED_FIFO."""


def set_fifo_priority(priority: int) -> None:
    """Put the calling thread under SCHED_FIFO at ``priority`` (1–99; Linux).

    Raises:
        PermissionError: the process may not (needs CAP_SYS_NICE or an ``rtprio`` limit).
    """
    os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(priority))


def fifo_refusal(priority: int, set_priority: Callable[[int], None] = set_fifo_priority) -> str:
    """Put the calling thread under SCHED_FIFO at ``priority`` (1–99) with ``set_priority``;
    '' when granted, else why not (the thread stays under the normal scheduler)."""
    try:
        set_priority(priority)
    except (PermissionError, OSError) as err:
        return f"SCHED_FIFO priority {priority} refused: {err}"
    return ""


def next_deadline(deadline: float, now: float, period: float) -> tuple[float, int]:
    """The first deadline after ``now`` on the grid ``deadline + k·period`` (k ≥ 1) [s], and how
    many grid deadlines were skipped because ``now`` had passed them.

    ``period`` [s] must be > 0. With ``now < deadline + period`` nothing is skipped.
    """
    if not period > 0.0:
        raise ValueError(f"period must be > 0 s, got {period!r}")
    following = deadline + period
    if now < following:
        return following, 0
    skipped = int((now - following) // period) + 1
    return following + skipped * period, skipped


class PeriodicThread:
    """Calls ``cycle()`` every ``period`` seconds in a daemon thread until :meth:`stop`.

    ``cycle`` must not raise: an exception escaping it ends the loop after ``on_error(err)``
    was called (the owner makes the robot safe there). ``priority`` > 0 asks for SCHED_FIFO at
    that priority (as ros2_control's ``thread_priority``); when the system refuses, the loop
    runs under the normal scheduler and :attr:`priority_error` says why. ``clock`` [s],
    ``sleep`` and ``set_priority`` are the monotonic clock, sleep and
    :func:`set_fifo_priority` (tests replace them).
    """

    def __init__(
        self,
        period: float,
        cycle: Callable[[], None],
        on_error: Callable[[BaseException], None],
        *,
        name: str = "periodic",
        priority: int = 0,
        clock: Callable[[], float] = time.monotonic,
        sleep: Callable[[float], None] = time.sleep,
        set_priority: Callable[[int], None] = set_fifo_priority,
    ) -> None:
        if not period > 0.0:
            raise ValueError(f"period must be > 0 s, got {period!r}")
        if not PRIORITY_RANGE[0] <= priority <= PRIORITY_RANGE[1]:
            raise ValueError(f"priority must be in [{PRIORITY_RANGE[0]}, {PRIORITY_RANGE[1]}], "
                             f"got {priority!r}")
        self.priority = priority
        self._set_priority = set_priority
        self._started = threading.Event()
        self.priority_error: str | None = None
        """Why SCHED_FIFO was refused (None: not asked for, or granted)."""
        self.period = period
        self._cycle, self._on_error = cycle, on_error
        self._clock, self._sleep = clock, sleep
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name=name, daemon=True)
        self.cycles = 0
        """Cycles run."""
        self.overruns = 0
        """Deadlines skipped because a cycle (or the thread's wake-up) was late."""
        self.error: BaseException | None = None
        """What ended the loop, if a cycle raised."""

    def start(self) -> None:
        """Start the thread (and wait until its priority is settled); the first cycle runs one
        period later."""
        self._thread.start()
        self._started.wait(1.0)

    def stop(self, timeout: float = 1.0) -> bool:
        """Ask the loop to end after its current cycle and wait up to ``timeout`` [s] for it;
        True when the thread has ended (or never started)."""
        self._stop.set()
        if self._thread.is_alive() and threading.current_thread() is not self._thread:
            self._thread.join(timeout)
        return not self._thread.is_alive()

    @property
    def running(self) -> bool:
        """The thread is alive."""
        return self._thread.is_alive()

    def _run(self) -> None:
        if self.priority > 0:
            self.priority_error = fifo_refusal(self.priority, self._set_priority) or None
        self._started.set()
        deadline = self._clock()
        while not self._stop.is_set():
            deadline, skipped = next_deadline(deadline, self._clock(), self.period)
            self.overruns += skipped
            delay = deadline - self._clock()
            if delay > 0.0:
                self._sleep(delay)
            if self._stop.is_set():
                return
            try:
                self._cycle()
            except BaseException as err:  # the owner stops the robot in on_error
                self.error = err
                self._on_error(err)
                return
            self.cycles += 1
