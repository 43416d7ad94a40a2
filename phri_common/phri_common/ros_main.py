"""Process entry point shared by every phri node: spin until Ctrl-C / SIGTERM, then clean up.

Executor. ``PHRI_EXECUTOR`` picks it per process: ``events`` (default,
``rclpy.experimental.events_executor.EventsExecutor``) or ``single`` (rclpy's
``SingleThreadedExecutor``). Measured with rclpy 9.1.2 from the Kilted wheels (docs/interfaces.md
"Processes and executor"; ``bench/bench_executor.py``):

* ``EventsExecutor.spin()`` (the blocking C++ loop) busy-loops whether or not a node owns a
  timer, runs no timer callback, and never returns to Python, so Python signal
  handlers never run and SIGINT/SIGTERM are ignored (only SIGKILL ends the process).
* ``EventsExecutor.spin_once(timeout_sec=0.1)`` in a Python loop does none of that: timers fire
  on time (a 500 Hz timer: 499 callbacks/s), the process idles, other Python threads
  keep the GIL, and the signal handlers run between calls (≤ 0.1 s to stop).
* Driven that way it costs a third to a half of the single-threaded executor's CPU for the same
  callbacks (docs/benchmarks.md, "Executors"), and every node's tests pass with it (timers,
  subscriptions, services, parameter services).

* ``spin_once`` runs exactly one callback per call (a node with a 500 Hz timer and five
  500 Hz subscriptions: 3,000 Python → C++ → Python round trips a second).
  ``spin_until_future_complete(future, timeout_sec=0.1)`` with a future that never completes
  runs the same loop in C++ for 0.1 s (``run_for``): every callback in that slice, timers on
  time, the GIL released while it waits, and it returns to Python after 0.1 s. The controller
  node at 500 Hz with its five inputs costs less CPU than with ``spin_once``
  (``bench/bench_controller.py --node-only --loop``; docs/benchmarks.md, "Executors").

* But a slice ends by its timeout only while the executor keeps up: when callbacks outlast
  their periods (a callback always due), the events executor never leaves the slice (measured:
  a 2 ms timer whose callback takes 3 ms).

So the events executor is driven here (:class:`SliceSpinner`) in slices of 0.1 s of
``spin_until_future_complete`` with a fresh future per slice (the executor adds a done-callback
to it every call) in a loop that ends when the stop flag set by the SIGINT/SIGTERM handlers is
up; the handlers also complete the running slice's future, which ends the slice after the
current callback even when overloaded. A signal stops the process within 0.1 s, or one callback
when overloaded; ``spin()`` is never called. ``PHRI_EXECUTOR=single`` keeps rclpy's supported
executor available, driven as before with ``spin_once(timeout_sec=0.1)`` (slices were not
measured for it on a quiet machine).
"""

from __future__ import annotations

import inspect
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
from rclpy.task import Future

from phri_common.settle import settle

EXECUTOR_ENV = "PHRI_EXECUTOR"
"""Environment variable that picks the executor of every phri process."""
EXECUTORS = ("events", "single")
"""Its allowed values; the first is the default."""


def make_executor(kind: str | None = None, context: Context | None = None) -> Executor:
    """The executor named by ``kind`` (default: ``$PHRI_EXECUTOR``, else ``events``).

    Drive it with :class:`SliceSpinner` (or ``spin_once``), never ``spin()`` (module
    docstring).

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


SLICE_S = 0.1
"""How long one executor call may run before the loop looks at its stop flag again [s]."""


class SliceSpinner:
    """Drives an executor in slices of ``slice_s`` seconds (module docstring).

    A slice ends after ``slice_s`` only while the executor keeps up: when callbacks outlast
    their periods (a callback is always due), rclpy 9.1.2's EventsExecutor never leaves the
    slice. :meth:`interrupt` (safe in a signal handler, or from another thread) completes the
    running slice's future, which ends the slice after the current callback, and keeps any later
    slice from starting.
    """

    def __init__(self, executor: Executor, slice_s: float = SLICE_S) -> None:
        self.executor = executor
        self.slice_s = slice_s
        self._future: Future[None] = Future()
        self._interrupted = False

    def spin_slice(self) -> None:
        """Run every callback that becomes due within the slice, then return."""
        future: Future[None] = Future()
        self._future = future
        if self._interrupted:  # interrupted before this slice's future existed
            return
        if isinstance(self.executor, SingleThreadedExecutor):
            # rclpy's Python executor: kept on the loop it was measured with (one callback
            # per call); slices were not measured for it on a quiet machine.
            self.executor.spin_once(timeout_sec=self.slice_s)
            return
        self.executor.spin_until_future_complete(future, timeout_sec=self.slice_s)

    def interrupt(self) -> None:
        """End the running slice now and every later one at once."""
        self._interrupted = True
        future = self._future
        if not future.done():
            future.set_result(None)

    def spin_until(self, stopped: Callable[[], bool]) -> None:
        """Spin slice after slice until ``stopped()`` or rclpy's context is shut down."""
        while not stopped() and rclpy.ok(context=self.executor.context):
            self.spin_slice()


def spin_slice(executor: Executor, slice_s: float = SLICE_S) -> None:
    """One slice of ``slice_s`` seconds (:class:`SliceSpinner`; benchmarks and tests)."""
    SliceSpinner(executor, slice_s).spin_slice()


def timer_callback(callback: Callable[[], object]) -> Callable[[], None]:
    """``callback`` for ``create_timer``, with its (empty) signature attached.

    rclpy 9.1.2's EventsExecutor calls ``inspect.signature`` on a timer's callback at every
    call (to pass a ``TimerInfo`` to callbacks that ask for one), which costs less for a
    function carrying ``__signature__`` than for a bound method (docs/benchmarks.md,
    "Executors"). The returned function takes no argument, as the executor then sees.
    """

    def call() -> None:
        callback()

    call.__signature__ = inspect.Signature()  # type: ignore[attr-defined]
    return call


def failed(nodes: Sequence[Node]) -> str | None:
    """The first node's unrecoverable error, as ``"<node>: <error>"``: a node whose own thread
    ended on an error sets its ``fatal_error`` attribute (e.g. the controller's control thread),
    and ``run_nodes`` then ends the process with code 1, as an exception escaping a callback
    would."""
    for node in nodes:
        error = getattr(node, "fatal_error", None)
        if error is not None:
            return f"{node.get_name()}: {error!r}"
    return None


def run_nodes(
    make_nodes: Callable[[], Sequence[Node]],
    name: str,
    args: Sequence[str] | None = None,
) -> int:
    """Create nodes, spin them until SIGINT/SIGTERM or a node's ``fatal_error`` (:func:`failed`:
    exit code 1), destroy them (nodes send their zero command in ``destroy_node``) and return the
    process exit code.

    Before the nodes are made and again once they exist, :func:`phri_common.settle.settle`
    moves start-up's objects out of the garbage collector's way and fills the cache rclpy's
    logger looks callers up in (the one-off pauses that cost the chain its dropped frames;
    docs/benchmarks.md, "End to end"); the first call, before any node thread or port reader
    runs, takes the bulk of it.

    A ``ValueError`` while creating the executor or the nodes (e.g. a refused parameter) is
    printed with the node name and gives exit code 2 instead of a traceback.
    """
    rclpy.init(
        args=list(args) if args is not None else sys.argv,
        signal_handler_options=SignalHandlerOptions.NO,
    )
    stop = False
    spinner: SliceSpinner | None = None

    def request_stop(signum: int, frame: FrameType | None) -> None:
        del signum, frame
        nonlocal stop
        stop = True
        if spinner is not None:
            spinner.interrupt()  # an overloaded slice would not end by itself

    previous = {sig: signal.signal(sig, request_stop) for sig in (signal.SIGINT, signal.SIGTERM)}
    nodes: Sequence[Node] = ()
    try:
        try:
            executor = make_executor()
            settle()  # the imports' objects, before any node's thread or port reader runs
            nodes = make_nodes()
        except ValueError as err:
            print(f"{name}: {err}", file=sys.stderr)
            return 2
        for node in nodes:
            executor.add_node(node)
        settle()  # the nodes' own objects (cheap after the first call: docs/benchmarks.md)
        spinner = SliceSpinner(executor)
        spinner.spin_until(lambda: stop or failed(nodes) is not None)
        failure = failed(nodes)
        if failure is not None:
            print(f"{name}: {failure}", file=sys.stderr)
            return 1
        return 0
    finally:
        for node in nodes:
            node.destroy_node()
        rclpy.try_shutdown()
        for sig, handler in previous.items():
            signal.signal(sig, handler)
