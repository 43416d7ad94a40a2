"""Benchmark: rclpy's executors as phri drives them, and the conditions of EventsExecutor's faults.

Each case runs in a child process: one node, optionally a 500 Hz timer, a Python thread that
wakes every 2 ms (a stand-in for the skin driver's serial thread; its wake-up lateness shows
whether the executor holds the GIL), spun with ``spin()`` (the executor's own loop), with
``spin_once(timeout_sec=0.1)`` in a Python loop, or in 0.1 s slices of
``spin_until_future_complete`` (``slices``: ``phri_common.ros_main.run_nodes``). The
parent measures the child's CPU from ``/proc`` over ``--seconds``, then sends SIGINT and waits
2 s (then SIGTERM, then SIGKILL), and prints how long after the signal the child ended. The
child installs its own SIGINT/SIGTERM handlers that set a stop flag, as ``run_nodes`` does (and
raise ``KeyboardInterrupt`` to leave ``spin()``, as rclpy's own handler does). Two more cases
overload the slices (each timer callback busy for 3 ms of its 2 ms period: a callback is always
due), where only the handlers' interruption can end a slice. (The tests,
``phri_common/test/test_ros_main.py``, check that timers run and that a signal stops the
process; how fast is measured here.)

Run: ``.venv/bin/python bench/bench_executor.py [--seconds 3]``.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from pathlib import Path

from phri_common.procstat import load_line, process_cpu_s
from phri_common.testing import isolate_ros_environment

BUSY_S = 0.003
"""Busy time of each timer callback in the overloaded cases [s] (the period is 2 ms)."""
CASES = [*((ex, loop, timer, 0.0) for ex in ("single", "events")
           for loop in ("slices", "spin_once", "spin") for timer in (False, True)),
         *((ex, "slices", True, BUSY_S) for ex in ("single", "events"))]


def counting_tick(ticks: list[int], busy_s: float) -> Callable[[], None]:
    """A timer callback that counts its calls in ``ticks[0]`` and spins ``busy_s`` [s]."""

    def tick() -> None:
        ticks[0] += 1
        end = time.monotonic() + busy_s
        while time.monotonic() < end:
            pass

    return tick


def child(kind: str, loop: str, timer: bool, report: str, busy_s: float = 0.0) -> None:
    """One case (see the module docstring); writes 'timer/s thread-p99-ms' to ``report``.

    ``busy_s`` [s]: each timer callback spins this long (overload when above 2 ms)."""
    import rclpy
    from rclpy.signals import SignalHandlerOptions

    from phri_common.ros_main import SliceSpinner, make_executor

    rclpy.init(signal_handler_options=SignalHandlerOptions.NO)
    node = rclpy.create_node("bench_executor")
    ticks = [0]
    if timer:
        node.create_timer(0.002, counting_tick(ticks, busy_s))
    stop = threading.Event()
    executor = make_executor(kind)
    executor.add_node(node)
    spinner = SliceSpinner(executor)

    def on_signal(_sig: int, _frame: object) -> None:
        stop.set()
        spinner.interrupt()  # as run_nodes' handlers: ends an overloaded slice
        if loop == "spin":  # spin() has no stop flag: leave it the way rclpy's handler does
            raise KeyboardInterrupt

    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, on_signal)
    lateness: list[float] = []

    def serial_thread() -> None:
        due = time.monotonic()
        while not stop.is_set():
            due += 0.002
            time.sleep(max(0.0, due - time.monotonic()))
            lateness.append(time.monotonic() - due)

    threading.Thread(target=serial_thread, daemon=True).start()
    start = time.monotonic()

    def write_report() -> None:
        late = sorted(lateness[50:]) or [float("nan")]
        elapsed = time.monotonic() - start
        Path(report).write_text(f"{ticks[0] / elapsed:.0f} "
                                f"{1e3 * late[int(0.99 * (len(late) - 1))]:.2f}")

    threading.Timer(1.0, write_report).start()
    if loop == "spin":
        with contextlib.suppress(KeyboardInterrupt):
            executor.spin()
    elif loop == "slices":  # phri_common.ros_main.run_nodes
        spinner.spin_until(stop.is_set)
    else:
        while not stop.is_set():
            executor.spin_once(timeout_sec=0.1)
    write_report()
    rclpy.try_shutdown()


def stop_child(proc: subprocess.Popen[bytes]) -> str:
    """SIGINT, then SIGTERM, then SIGKILL, 2 s apart; say which one ended it and how long after
    it was sent [ms]."""
    for sig, name in ((signal.SIGINT, "SIGINT"), (signal.SIGTERM, "SIGTERM")):
        sent = time.monotonic()
        proc.send_signal(sig)
        try:
            proc.wait(2.0)
            return f"stops on {name} ({1e3 * (time.monotonic() - sent):.0f} ms)"
        except subprocess.TimeoutExpired:
            continue
    proc.kill()
    proc.wait()
    return "ignores SIGINT and SIGTERM (killed)"


def run_case(kind: str, loop: str, timer: bool, busy_s: float, seconds: float,
             tmp: Path) -> str:
    """One case in a child process: its table row."""
    report = tmp / f"{kind}-{loop}-{timer}-{busy_s}.txt"
    proc = subprocess.Popen([sys.executable, __file__, "--child", kind, loop, str(int(timer)),
                             str(report), str(busy_s)], stderr=subprocess.DEVNULL)
    time.sleep(1.5)  # start-up
    cpu0, t0 = process_cpu_s(proc.pid), time.monotonic()
    time.sleep(seconds)
    cpu = (process_cpu_s(proc.pid) - cpu0) / (time.monotonic() - t0)
    ending = stop_child(proc)
    rate, late = (report.read_text().split() if report.exists() else ("n/a", "n/a"))
    timer_text = "500 Hz" if timer else "none"
    if busy_s > 0.0:
        timer_text += f", {1e3 * busy_s:g} ms callbacks"
    return (f"| {kind} | {loop} | {timer_text} | {100 * cpu:.0f} % | "
            f"{rate if timer else '–'} | {late} | {ending} |")


def main() -> int:
    if len(sys.argv) > 1 and sys.argv[1] == "--child":
        child(sys.argv[2], sys.argv[3], sys.argv[4] == "1", sys.argv[5], float(sys.argv[6]))
        return 0
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument("--seconds", type=float, default=3.0, help="measured seconds per case")
    args = parser.parse_args()
    isolate_ros_environment()
    import tempfile

    print(load_line())
    print("| executor | loop | timer | CPU (one core) | timer callbacks/s | "
          "thread wake-up lateness p99 ms | SIGINT |")
    print("|---|---|---|---:|---:|---:|---|")
    with tempfile.TemporaryDirectory() as tmp:
        for kind, loop, timer, busy_s in CASES:
            print(run_case(kind, loop, timer, busy_s, args.seconds, Path(tmp)), flush=True)
    print(load_line())
    return 0


if __name__ == "__main__":
    os.environ.setdefault("RCUTILS_LOGGING_SEVERITY", "WARN")
    sys.exit(main())
