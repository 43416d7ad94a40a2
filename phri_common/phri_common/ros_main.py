"""Process entry point shared by every phri node: spin until Ctrl-C / SIGTERM, then clean up.

Why not ``rclpy.experimental.events_executor.EventsExecutor``: with rclpy 9.1 (Kilted wheels) its
``spin()`` busy-loops at ~96 % of a core as soon as a node owns a timer, and it ignores SIGINT and
SIGTERM (measured; see docs/skin_driver.md "Executor"). A node that cannot be stopped with Ctrl-C
cannot send its final zero command, so every phri process uses the single-threaded executor with
an explicit stop flag set from the signal handlers.
"""

from __future__ import annotations

import signal
import sys
from collections.abc import Callable, Sequence
from types import FrameType

import rclpy
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.signals import SignalHandlerOptions


def run_nodes(
    make_nodes: Callable[[], Sequence[Node]],
    name: str,
    args: Sequence[str] | None = None,
) -> int:
    """Create nodes, spin them until SIGINT/SIGTERM, destroy them (nodes send their zero command
    in ``destroy_node``) and return the process exit code.

    A ``ValueError`` while creating the nodes (e.g. a refused parameter) is printed with the node
    name and gives exit code 2 instead of a traceback.
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
            nodes = make_nodes()
        except ValueError as err:
            print(f"{name}: {err}", file=sys.stderr)
            return 2
        executor = SingleThreadedExecutor()
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
