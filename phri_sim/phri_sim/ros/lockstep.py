"""Waiting in lock-step on simulated progress, never on the host's speed.

Each phase of a lock-step control period (:mod:`phri_sim.ros.runner`) hands the nodes their
inputs and then spins the executor until every message it expects for this period has been taken
(this period's contact states, joint state and odometry held by the controller; a new command on
each command channel). Simulated time moves on only when nothing is missing, so how long a phase
takes on the host never changes the run: a busy machine makes a run slower, not different, and
never ends it.

What ends a run is a node that can no longer answer, and :class:`LockStep` tells which:

* at once (within :data:`ALIVE_CHECK_PERIOD` of wall time), when a node of the run has been
  destroyed or taken off the executor, its control loop died (``fatal_error``), or the context
  was shut down;
* when, for :data:`STALL_LIMIT` of wall time, nothing the phase waits for arrived: a node that is
  alive but silent (a timer that no longer fires, messages that never reach their subscriber).
  The bound is very generous on purpose: it only keeps a genuinely dead run from hanging forever,
  and any arrival restarts it, so a slow host that trickles messages in is waited for. A warning
  names what is missing after :data:`STALL_WARNING` of silence.

Either way :class:`LockStepError` names the phase, what is missing and the simulation time.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from typing import Any

STALL_LIMIT = 600.0
"""Wall time [s] a phase may go without any awaited message arriving before the run is declared
stuck (a dead node). Any arrival restarts the count."""
STALL_WARNING = 10.0
"""Wall time [s] of such silence after which one warning names what is missing."""
SPIN_SLICE = 0.05
"""Longest single wait of the executor [s] between two checks."""
ALIVE_CHECK_PERIOD = SPIN_SLICE
"""Wall time [s] between two checks that the run's nodes are alive while a phase waits: a
phase spins the executor about 28 times per control period, one callback a spin, and asking
every node whether it still exists on every spin cost a twentieth of the run."""

Missing = Callable[[], Sequence[str]]
"""What a phase still waits for (topic or channel names); empty when the phase is complete."""


class LockStepError(RuntimeError):
    """A lock-step phase cannot complete: a node of the run died or stopped answering."""


def dead_node(node: Any, name: str, executor: Any, spun: Sequence[Any] | None = None
              ) -> str | None:
    """Why ``node`` (called ``name``) can no longer answer (destroyed, off the executor, its
    control loop ended with an error), or None while it can. ``spun``: the executor's nodes,
    when the caller already asked for them."""
    try:
        node.get_name()
    except Exception:  # rclpy's InvalidHandle: the node was destroyed
        return f"node {name} was destroyed"
    if node not in (executor.get_nodes() if spun is None else spun):
        return f"node {name} is no longer spun by the run's executor"
    error = getattr(node, "fatal_error", None)
    if error is not None:
        return f"node {name} stopped on an error: {error!r}"
    return None


class LockStep:
    """Spins one run's executor until a phase is complete (module docstring).

    Args:
        executor: the run's executor (``spin_once``, ``get_nodes``).
        context: the run's rclpy context (``ok``).
        nodes: the nodes the run needs alive.
        warn: called once per phase with a warning after :data:`STALL_WARNING` of silence.
        clock: wall clock [s] for the stall bound (tests give a fake one).
    """

    def __init__(self, executor: Any, context: Any, nodes: Sequence[Any], *,
                 warn: Callable[[str], None] | None = None,
                 clock: Callable[[], float] = time.monotonic) -> None:
        self.executor = executor
        self.context = context
        self.nodes = [(node, node.get_name()) for node in nodes]
        """The run's nodes and their names (a destroyed node can no longer tell it)."""
        self.warn = warn
        self.clock = clock
        self.stall_limit = STALL_LIMIT
        """Wall time [s] without any awaited arrival that ends the run."""
        self.stall_warning = STALL_WARNING
        """Wall time [s] without any awaited arrival after which one warning is given."""

    def check_alive(self, what: str, sim_time: float) -> None:
        """:class:`LockStepError` if the context is down or a node of the run is dead."""
        if not self.context.ok():
            raise LockStepError(f"lock-step: the context was shut down while waiting for {what} "
                                f"at sim time {sim_time:.3f} s")
        spun = self.executor.get_nodes()
        for node, name in self.nodes:
            why = dead_node(node, name, self.executor, spun)
            if why is not None:
                raise LockStepError(f"lock-step: {why} while waiting for {what} at sim time "
                                    f"{sim_time:.3f} s")

    def wait(self, missing: Missing, what: str, sim_time: float) -> None:
        """Spin until ``missing()`` is empty; :class:`LockStepError` when a node is dead or
        nothing awaited arrived for :attr:`stall_limit` [s] of wall time.

        Args:
            missing: what the phase still waits for (module docstring).
            what: the phase, for messages (e.g. ``sensor data``).
            sim_time: the simulation time of the phase [s], for messages.
        """
        waiting = list(missing())
        if not waiting:
            return
        since = checked = self.clock()
        warned = False
        while True:
            self.executor.spin_once(timeout_sec=SPIN_SLICE)
            now_missing = list(missing())
            if not now_missing:
                return
            now = self.clock()
            if now - checked >= ALIVE_CHECK_PERIOD:
                self.check_alive(what, sim_time)
                checked = now
            if now_missing != waiting:  # something arrived: the run is progressing
                waiting, since, warned = now_missing, now, False
            silent = now - since
            if silent > self.stall_limit:
                raise LockStepError(
                    f"lock-step: nothing arrived for {silent:.0f} s of wall time while waiting "
                    f"for {what} at sim time {sim_time:.3f} s; missing: {', '.join(waiting)} (a "
                    "node stopped answering)")
            if silent > self.stall_warning and not warned and self.warn is not None:
                warned = True
                self.warn(f"lock-step: still waiting for {what} at sim time {sim_time:.3f} s "
                          f"after {silent:.0f} s of wall time; missing: {', '.join(waiting)} "
                          "(a busy host, or a node that stopped answering)")
