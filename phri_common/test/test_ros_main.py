"""phri_common.ros_main: executor choice (PHRI_EXECUTOR) and stopping on SIGINT/SIGTERM.

The process tests run ``run_nodes`` in a child with a 500 Hz timer: the timer must run (the
child says so after its 20th call), and a signal sent while it runs must end the process with
exit code 0 after its ``destroy_node``, with either executor. (``EventsExecutor.spin()`` would
fail both: it runs no timer and ignores the signals; see the module docstring.) How fast the
timer runs and how soon a signal stops the process are measured by ``bench/bench_executor.py``
(timer callbacks/s; stopped by SIGINT within 2 s), not here: the waits below only bound a
stalled machine.
"""

from __future__ import annotations

import os
import queue
import signal
import subprocess
import sys
import textwrap
import threading
import time

import pytest
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor

from phri_common.ros_main import EXECUTOR_ENV, EXECUTORS, make_executor

CHILD = textwrap.dedent("""
    import os, sys, time
    import rclpy
    from phri_common.ros_main import run_nodes

    class Ticker(rclpy.node.Node):
        def __init__(self):
            super().__init__("ticker")
            self.ticks = 0
            self.start = time.monotonic()
            self.create_timer(0.002, self.tick)
            print("ready", flush=True)

        def tick(self):
            self.ticks += 1
            if self.ticks == 20:
                print("ticking", flush=True)
            busy = float(os.environ.get("TICKER_BUSY_S", "0"))
            end = time.monotonic() + busy
            while time.monotonic() < end:
                pass

        def destroy_node(self):
            print(f"destroyed {self.ticks}", flush=True)
            super().destroy_node()

    sys.exit(run_nodes(lambda: [Ticker()], "ticker"))
""")


def start_child(executor: str, busy_s: float = 0.0) -> subprocess.Popen[str]:
    """The ticker child; ``busy_s`` > 0.002 makes each tick outlast its period (overload)."""
    env = dict(os.environ, **{EXECUTOR_ENV: executor, "TICKER_BUSY_S": str(busy_s)})
    return subprocess.Popen([sys.executable, "-c", CHILD], env=env, text=True,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)


def test_default_executor_is_the_events_executor(
    monkeypatch: pytest.MonkeyPatch, ros_context: Context
) -> None:
    monkeypatch.delenv(EXECUTOR_ENV, raising=False)
    executor = make_executor(context=ros_context)
    assert type(executor).__name__ == "EventsExecutor"
    executor.shutdown()


def test_single_threaded_executor_is_chosen_by_the_environment(
    monkeypatch: pytest.MonkeyPatch, ros_context: Context
) -> None:
    monkeypatch.setenv(EXECUTOR_ENV, "single")
    executor = make_executor(context=ros_context)
    assert isinstance(executor, SingleThreadedExecutor)
    executor.shutdown()


def test_events_executor_is_chosen_by_the_environment(
    monkeypatch: pytest.MonkeyPatch, ros_context: Context
) -> None:
    monkeypatch.setenv(EXECUTOR_ENV, "events")
    executor = make_executor(context=ros_context)
    assert type(executor).__name__ == "EventsExecutor"
    executor.shutdown()


def test_unknown_executor_is_refused_naming_variable_value_and_choices(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setenv(EXECUTOR_ENV, "multi")
    with pytest.raises(ValueError, match=r"PHRI_EXECUTOR refused value 'multi'.*'events'"):
        make_executor()


WAIT_S = 60.0
"""Longest wait for something that must happen (a stalled machine); never a measured time."""


def signal_while_ticking(proc: subprocess.Popen[str], sig: int) -> tuple[str, str]:
    """Wait until the child's timer has run 20 times ("ticking": it is spinning), send ``sig``;
    its (stdout, stderr) once it ended. A child that does not end is killed (and fails)."""
    assert proc.stdout is not None and proc.stderr is not None
    lines: queue.Queue[str] = queue.Queue()
    out: list[str] = []
    err: list[str] = []

    def read_stdout() -> None:
        for line in proc.stdout:  # type: ignore[union-attr]
            out.append(line)
            lines.put(line.strip())
        lines.put("")  # end of output

    readers = [threading.Thread(target=read_stdout, daemon=True),
               threading.Thread(target=lambda: err.extend(proc.stderr), daemon=True)]  # type: ignore[arg-type]
    for reader in readers:
        reader.start()
    try:
        seen = [lines.get(timeout=WAIT_S) for _ in range(2)]
        assert seen == ["ready", "ticking"], f"{seen} {''.join(err)[-2000:]}"
        proc.send_signal(sig)
        proc.wait(timeout=WAIT_S)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
        for reader in readers:
            reader.join(WAIT_S)
    return "".join(out), "".join(err)


@pytest.mark.parametrize("executor", EXECUTORS)
@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_run_nodes_runs_timers_and_stops_on_signal(executor: str, sig: int) -> None:
    proc = start_child(executor)
    out, err = signal_while_ticking(proc, sig)
    assert proc.returncode == 0, err[-2000:]
    ticks = int(out.split("destroyed")[1])
    assert ticks >= 20  # the timer ran until the signal, then destroy_node ran


def test_run_nodes_refuses_an_unknown_executor_with_exit_code_2() -> None:
    proc = start_child("fastest")
    _out, err = proc.communicate(timeout=WAIT_S)
    assert proc.returncode == 2
    assert "ticker: environment variable PHRI_EXECUTOR refused value 'fastest'" in err


def test_interfaces_page_documents_the_executor_variable_its_values_and_default() -> None:
    from pathlib import Path

    page = (Path(__file__).resolve().parents[2] / "docs" / "interfaces.md").read_text()
    rows = [line for line in page.splitlines() if line.startswith(f"| `{EXECUTOR_ENV}` |")]
    assert len(rows) == 1
    cells = [c.strip() for c in rows[0].strip("|").split("|")]
    assert cells[1] == ", ".join(f"`{v}`" for v in EXECUTORS)
    assert cells[2] == f"`{EXECUTORS[0]}`"


def test_one_slice_runs_every_callback_due_in_it_then_returns(ros_context: Context) -> None:
    """One spin_slice call runs a 500 Hz timer many times (spin_once: once) until its slice
    ends: here the 10th callback interrupts a slice of 10 minutes, which then returns at once.
    Left alone, a slice returns after its time (a loop around it can see its stop flag)."""
    import rclpy

    from phri_common.ros_main import SliceSpinner, spin_slice

    node = rclpy.create_node("slice_ticker", context=ros_context)
    ticks = [0]
    long_slice = SliceSpinner(make_executor("events", context=ros_context), slice_s=600.0)

    def tick() -> None:
        ticks[0] += 1
        if ticks[0] == 10:
            long_slice.interrupt()

    node.create_timer(0.002, tick)
    executor = long_slice.executor
    executor.add_node(node)
    try:
        start = time.monotonic()
        long_slice.spin_slice()
        # One call, ten callbacks, ended by the interruption (600 s of a 500 Hz timer: 300,000).
        assert 10 <= ticks[0] <= 12 and time.monotonic() - start < WAIT_S
        start = time.monotonic()
        spin_slice(executor, 0.2)
        assert time.monotonic() - start >= 0.19  # not interrupted: the whole slice
        calls = [0]

        def stopped() -> bool:
            calls[0] += 1
            return calls[0] > 3

        SliceSpinner(executor, slice_s=0.05).spin_until(stopped)
        assert calls[0] == 4  # 3 slices, each returned after its time, then the stop
    finally:
        executor.shutdown()
        node.destroy_node()


def test_timer_callback_calls_through_and_declares_no_parameters(ros_context: Context) -> None:
    """What EventsExecutor inspects at every timer call is attached: no parameters (so no
    TimerInfo is passed), and the timer still runs the wrapped callback."""
    import inspect

    import rclpy

    from phri_common.ros_main import spin_slice, timer_callback

    calls: list[int] = []
    wrapped = timer_callback(lambda: calls.append(1))
    assert inspect.signature(wrapped).parameters == {}
    assert "__signature__" in vars(wrapped)
    node = rclpy.create_node("timer_callback_test", context=ros_context)
    node.create_timer(0.002, wrapped)
    executor = make_executor("events", context=ros_context)
    executor.add_node(node)
    try:
        deadline = time.monotonic() + WAIT_S
        while len(calls) < 10 and time.monotonic() < deadline:
            spin_slice(executor, 0.1)
        assert len(calls) >= 10
    finally:
        executor.shutdown()
        node.destroy_node()


@pytest.mark.parametrize("executor", EXECUTORS)
@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_run_nodes_stops_on_signal_while_overloaded(executor: str, sig: int) -> None:
    """Each tick (3 ms) outlasts its 2 ms period, so a callback is always due: the process must
    still stop on the signal (a slice of the events executor never ends by its timeout then;
    the signal must end it). The signal comes after the 20th tick: while overloaded."""
    proc = start_child(executor, busy_s=0.003)
    out, err = signal_while_ticking(proc, sig)
    assert proc.returncode == 0, err[-2000:]
    assert "destroyed" in out


FAILING_CHILD = textwrap.dedent("""
    import sys, threading
    import rclpy
    from phri_common.ros_main import run_nodes

    class Failing(rclpy.node.Node):
        '''A node whose own thread fails after 0.3 s (as the controller's control thread can).'''
        def __init__(self):
            super().__init__("failing")
            self.fatal_error = None
            threading.Timer(0.3, self.fail).start()

        def fail(self):
            self.fatal_error = RuntimeError("control thread broke")

        def destroy_node(self):
            print("destroyed", flush=True)
            super().destroy_node()

    sys.exit(run_nodes(lambda: [Failing()], "failing_process"))
""")


def test_run_nodes_ends_with_exit_code_1_when_a_node_reports_a_fatal_error() -> None:
    proc = subprocess.Popen([sys.executable, "-c", FAILING_CHILD], text=True,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    try:
        out, err = proc.communicate(timeout=WAIT_S)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 1, err[-2000:]
    assert "destroyed" in out  # the nodes were torn down (the controller's zero command)
    assert "failing_process: failing: RuntimeError('control thread broke')" in err
