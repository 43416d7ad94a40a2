"""Process entry point shared by every phri node: spin until Ctrl-C / SIGTERM, then clean up.

Executor. ``PHRI_EXECUTOR`` picks it per process: ``events`` (default,
``rclpy.experimental.events_executor.EventsExecutor``) or ``single`` (rclpy's
``SingleThreadedExecutor``). Measured with rclpy 9.1.2 from the Kilted wheels (docs/interfaces.md
"Processes and executor"; ``bench/bench_executor.py``):

* ``EventsExecutor.spin()`` (the blocking C++ loop) busy-loops at 50–100 % of a core whether or
  not a node owns a timer, runs no timer callback, and never returns to Python, so Python signal
  handlers never run and SIGINT/SIGTERM are ignored (only SIGKILL ends the process).
* ``EventsExecutor.spin_once(timeout_sec=0.1)`` in a Python loop does none of that: timers fire
  on time (a 500 Hz timer: 499 callbacks/s), the process idles at ≈ 0 %, other Python threads
  keep the GIL, and the signal handlers run between calls (≤ 0.1 s to stop).
* Driven that way it costs a third to a half of the single-threaded executor's CPU for the same
  callbacks (a 500 Hz timer: 9 % against 21 % of a core; the estimation node per frame
  delivered: about half), and every node's tests pass with it (timers, subscriptions,
  services, parameter services).

So both executors are driven the same way here: ``spin_once`` with a 0.1 s timeout in a loop
that ends when the stop flag set by the SIGINT/SIGTERM handlers is up; ``spin()`` is never
called. ``PHRI_EXECUTOR=single`` keeps rclpy's supported executor available.
"""

from __future__ import annotations

import os
import signal
import sys
from collections.abc import Callable, Sequence
from types import FrameType

import rclpy
from rclpy.context import Context
from rclpy.executors import Executor, SingleThreadedExecutor
from rclpy.node import Node
from rclpy.signals import SignalHandlerOptions

EXECUTOR_ENV = "PHRI_EXECUTOR"
"""Environment variable that picks the executor of every phri process."""
EXECUTORS = ("events", "single")
"""Its allowed values; the first is the default."""


def make_executor(kind: str | None = None, context: Context | None = None) -> Executor:
    """The executor named by ``kind`` (default: ``$PHRI_EXECUTOR``, else ``events``).

    Drive it with ``spin_once(timeout_sec=…)`` only (module docstring).

    Raises:
        ValueError: an unknown name (names the variable, the value and the allowed ones).
    """
    if kind is None:
        kind = os.environ.get(EXECUTOR_ENV, "") or EXECUTORS[0]
    if kind == "single":
        return SingleThreadedExecutor(context=context)
    if kind == "events":
        from rclpy.experimental.events_executor import EventsExecutor

        return EventsExecutor(context=context)
    raise ValueError(
        f"environment variable {EXECUTOR_ENV} refused value {kind!r}: allowed {list(EXECUTORS)}"
    )


def run_nodes(
    make_nodes: Callable[[], Sequence[Node]],
    name: str,
    args: Sequence[str] | None = None,
) -> int:
    """Create nodes, spin them until SIGINT/SIGTERM, destroy them (nodes send their zero command
    in ``destroy_node``) and return the process exit code.

    A ``ValueError`` while creating the executor or the nodes (e.g. a refused parameter) is
    printed with the node name and gives exit code 2 instead of a traceback.
    """
    rclpy.init(
        args=list(args) if args is not None else sys.argv,
        signal_handler_options=SignalHandlerOptions.NO,
    )
    stop = False

    def request_stop(signum: int, frame: FrameType | None) -> None:
        del signum, frame
        nonlocal stop
        stop = True

    previous = {sig: signal.signal(sig, request_stop) for sig in (signal.SIGINT, signal.SIGTERM)}
    nodes: Sequence[Node] = ()
    try:
        try:
            executor = make_executor()
            nodes = make_nodes()
        except ValueError as err:
            print(f"{name}: {err}", file=sys.stderr)
            return 2
        for node in nodes:
            executor.add_node(node)
        while not stop and rclpy.ok():
            executor.spin_once(timeout_sec=0.1)
        return 0
    finally:
        for node in nodes:
            node.destroy_node()
        rclpy.try_shutdown()
        for sig, handler in previous.items():
            signal.signal(sig, handler)
