"""The arm bridge's worker process and its never-blocking parent-side handle (pure: no rclpy).

Why a process: ur_rtde's constructor can block for minutes *holding the GIL* when a host accepts
the TCP connection and never answers (measured: a thread is not enough, the whole interpreter
stops). So every ur_rtde call lives in a worker process that owns the :class:`ArmInterface`, runs
the control loop (:func:`run_arm_loop`: read state → :class:`ArmSupervisor` → speedJ / speedStop
/ watchdog kick at ``rate_hz``) and talks to the ROS node over a socket pair:

* node → worker: ``("cmd", qd, stamp)`` (stamp = ``time.monotonic()`` at arrival, the same
  clock in both processes on Linux), ``("stop",)``;
* worker → node: ``("connecting",)``, ``("connected",)``, ``("failed", why)``,
  ``("report", WorkerReport)`` once per period.

Neither side ever blocks on the other: a message is sent only when the socket has room (else it
is dropped: commands and reports are "newest wins", and staleness is judged by stamps), and the
node only polls. :class:`ArmLink` (node side) kills a worker whose connect exceeds
``connect_timeout`` or whose reports stop for ``report_timeout`` and starts a fresh one after
``restart_delay``; the robot's RTDE watchdog stops the arm if the worker stalls while connected.
If the node dies, the worker sees the socket close (or the commands go stale) and stops the arm.

Monitor mode (:func:`run_monitor_loop`): the worker only reads the robot state and reports it;
it never calls speedJ, speedStop or the watchdog (a receive-only arm has no control interface),
and the node forwards no command to it.

Diagnostics keep the root cause: the reason a worker sent with ``("failed", why)`` (e.g. the
exception text of a failed connect) is what :attr:`LinkStatus.last_error` shows after the
worker exits, not the bare fact that it exited.
"""

from __future__ import annotations

import contextlib
import dataclasses
import multiprocessing
import select
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from multiprocessing.connection import Connection
from multiprocessing.process import BaseProcess
from typing import Any, Protocol

from phri_hardware.ur_arm import (
    Action,
    ArmInterface,
    ArmState,
    ArmSupervisor,
    BridgeConfig,
    Decision,
    SupervisorCounters,
    apply_decision,
    robot_fault,
)

RESTART_PROGRAM_INTERVAL = 2.0
"""Least time between two ``reuploadScript`` attempts after a protective stop [s]."""

MONITOR_HOLD = "monitor mode: receive only, commands are not accepted"
"""The worker's hold reason in monitor mode."""


class ArmFactory(Protocol):
    """Picklable callable that builds the arm inside the worker process."""

    def __call__(self) -> ArmInterface: ...


@dataclass(frozen=True)
class WorkerReport:
    """One period of the worker, sent to the node (joint states and diagnostics)."""

    stamp: float
    state: ArmState
    action: str
    hold_reason: str
    armed: bool
    moving: bool
    counters: SupervisorCounters
    overruns: int
    send_failures: int


def send_nowait(conn: Connection, message: object) -> bool:
    """Send ``message`` only if the socket has room now; return whether it was sent.

    A Unix socket reports writable while at least half its send buffer is free, far more than one
    message, so ``send`` cannot block after the check.
    """
    try:
        _, writable, _ = select.select([], [conn.fileno()], [], 0.0)
        if not writable:
            return False
        conn.send(message)
    except (OSError, ValueError):
        return False
    return True


def run_arm_loop(
    arm: ArmInterface,
    config: BridgeConfig,
    conn: Connection,
    watchdog_frequency: float,
    clock: Callable[[], float] = time.monotonic,
    sleep: Callable[[float], None] = time.sleep,
) -> str:
    """Connect ``arm`` and run the control loop until told to stop or the link breaks.

    Returns why it ended. The arm gets ``speedStop`` on every exit path after connecting.
    """
    if not _connect(arm, conn, watchdog_frequency):
        return "connect failed"
    supervisor = ArmSupervisor(config)
    overruns = 0
    send_failures = 0
    last_restart = -float("inf")
    reason = "stopped"
    next_tick = clock()
    try:
        while True:
            if _feed_commands(conn, supervisor):
                reason = "stop requested"
                break
            state = arm.read_state()
            now = clock()
            decision = supervisor.step(now, state)
            if not state.connected:
                send_nowait(conn, ("failed", "connection lost"))
                reason = "connection lost"
                break
            if _script_restart_due(decision, state, config, now - last_restart):
                last_restart = now
                arm.restart_program()
            if not apply_decision(arm, decision, config) and decision.action is Action.SPEED_J:
                send_failures += 1
            report = WorkerReport(
                stamp=now, state=state, action=decision.action.value,
                hold_reason=supervisor.hold_reason, armed=supervisor.armed,
                moving=supervisor.moving, counters=supervisor.counters, overruns=overruns,
                send_failures=send_failures,
            )
            send_nowait(conn, ("report", report))
            next_tick += config.period
            delay = next_tick - clock()
            if delay > 0.0:
                sleep(delay)
            else:
                overruns += 1
                if delay < -config.period:
                    next_tick = clock()  # resynchronise instead of bursting to catch up
    except (EOFError, OSError):
        reason = "node connection closed"
    finally:
        _final_stop(arm, supervisor.shutdown(), config)
        _safe_disconnect(arm)
    return reason


def _feed_commands(conn: Connection, supervisor: ArmSupervisor) -> bool:
    """Hand every waiting command to ``supervisor``; True when the node asked to stop."""
    stop = False
    for message in _drain(conn):
        if message[0] == "cmd":
            supervisor.command(message[1], float(message[2]))
        elif message[0] == "stop":
            stop = True
    return stop


def _script_restart_due(
    decision: Decision, state: ArmState, config: BridgeConfig, since_last: float
) -> bool:
    """A protective stop ends ur_rtde's control script; restart it once the robot is back in
    RUNNING/NORMAL (the supervisor stays disarmed until a ~zero command), at most every
    :data:`RESTART_PROGRAM_INTERVAL`."""
    return (
        decision.reason == "control script not running"
        and robot_fault(_with_program(state), config.allow_reduced_safety) is None
        and since_last >= RESTART_PROGRAM_INTERVAL
    )


def _connect(arm: ArmInterface, conn: Connection, watchdog_frequency: float) -> bool:
    """Connect ``arm`` (and set its watchdog when > 0 Hz); report the outcome to the node."""
    send_nowait(conn, ("connecting",))
    try:
        arm.connect()
        if watchdog_frequency > 0.0:
            arm.set_watchdog(watchdog_frequency)
    except Exception as err:  # any failure of the vendor library ends this attempt cleanly
        send_nowait(conn, ("failed", f"connect failed: {type(err).__name__}: {err}"))
        _safe_disconnect(arm)
        return False
    send_nowait(conn, ("connected",))
    return True


def run_monitor_loop(
    arm: ArmInterface,
    config: BridgeConfig,
    conn: Connection,
    clock: Callable[[], float] = time.monotonic,
    sleep: Callable[[float], None] = time.sleep,
) -> str:
    """Monitor mode: connect ``arm`` (receive only) and report its state at ``rate_hz``.

    Never sends a command to the arm (no speedJ, speedStop, watchdog or script upload);
    commands arriving from the node are discarded. Returns why it ended.
    """
    if not _connect(arm, conn, watchdog_frequency=0.0):
        return "connect failed"
    counters = SupervisorCounters()
    reason = "stopped"
    next_tick = clock()
    try:
        while True:
            if any(message[0] == "stop" for message in _drain(conn)):
                reason = "stop requested"
                break
            state = arm.read_state()
            if not state.connected:
                send_nowait(conn, ("failed", "connection lost"))
                reason = "connection lost"
                break
            report = WorkerReport(
                stamp=clock(), state=state, action=Action.NONE.value, hold_reason=MONITOR_HOLD,
                armed=False, moving=False, counters=counters, overruns=0, send_failures=0,
            )
            send_nowait(conn, ("report", report))
            next_tick += config.period
            sleep(max(0.0, next_tick - clock()))
    except (EOFError, OSError):
        reason = "node connection closed"
    finally:
        _safe_disconnect(arm)
    return reason


def _drain(conn: Connection) -> list[Any]:
    """Every message waiting on ``conn`` (never blocks)."""
    messages = []
    while conn.poll():
        messages.append(conn.recv())
    return messages


def _with_program(state: ArmState) -> ArmState:
    return dataclasses.replace(state, program_running=True)


def _final_stop(arm: ArmInterface, decision: Decision, config: BridgeConfig) -> None:
    # The connection may already be gone; the robot's watchdog then stops the arm.
    with contextlib.suppress(Exception):
        apply_decision(arm, decision, config)


def _safe_disconnect(arm: ArmInterface) -> None:
    with contextlib.suppress(Exception):
        arm.disconnect()


def worker_main(
    factory: ArmFactory,
    config: BridgeConfig,
    conn: Connection,
    watchdog_frequency: float,
    monitor: bool = False,
) -> None:
    """Process target: build the arm with ``factory`` and run :func:`run_arm_loop` (or
    :func:`run_monitor_loop` in monitor mode)."""
    try:
        arm = factory()
    except Exception as err:
        send_nowait(conn, ("failed", f"could not create the arm interface: {err}"))
        return
    if monitor:
        run_monitor_loop(arm, config, conn)
    else:
        run_arm_loop(arm, config, conn, watchdog_frequency)


@dataclass
class LinkStatus:
    """What the node knows about its worker (diagnostics)."""

    phase: str = "idle"
    """idle, connecting, running, failed, stopped."""
    last_error: str = ""
    attempts: int = 0
    connected_once: bool = False
    report: WorkerReport | None = None
    commands_dropped: int = 0
    worker_kills: int = 0
    history: list[str] = field(default_factory=list)


class ArmLink:
    """Node-side handle of the worker process. No method waits on the robot or the worker.

    Args:
        factory: builds the arm in the worker (picklable).
        config: decision logic configuration.
        connect_timeout: a connect that takes longer is abandoned (worker killed) [s].
        report_timeout: a connected worker silent this long is killed [s].
        restart_delay: wait before the next connection attempt [s].
        watchdog_frequency: ur_rtde watchdog minimum frequency [Hz] (0 = off).
        clock: monotonic clock [s].
        monitor: run the worker in monitor mode (receive only; commands are not sent).
    """

    def __init__(
        self,
        factory: ArmFactory,
        config: BridgeConfig,
        connect_timeout: float,
        report_timeout: float,
        restart_delay: float,
        watchdog_frequency: float,
        clock: Callable[[], float] = time.monotonic,
        monitor: bool = False,
    ) -> None:
        self._factory = factory
        self.monitor = monitor
        self._worker_error = ""  # why the current worker failed, as it reported
        self._config = config
        self._connect_timeout = connect_timeout
        self._report_timeout = report_timeout
        self._restart_delay = restart_delay
        self._watchdog_frequency = watchdog_frequency
        self._clock = clock
        self._ctx = multiprocessing.get_context("spawn")  # fork is unsafe with DDS threads
        self._process: BaseProcess | None = None
        self._conn: Connection | None = None
        self._started_at = 0.0
        self._last_message = 0.0
        self._restart_at = 0.0
        self._closed = False
        self.status = LinkStatus()

    def start(self) -> None:
        """Start a worker (returns after the process is launched, ~ms)."""
        parent, child = self._ctx.Pipe(duplex=True)
        process = self._ctx.Process(
            target=worker_main,
            args=(self._factory, self._config, child, self._watchdog_frequency, self.monitor),
            daemon=True,
            name="phri_arm_worker",
        )
        process.start()
        child.close()
        self._process, self._conn = process, parent
        self._started_at = self._last_message = self._clock()
        self._worker_error = ""
        self.status.phase = "connecting"
        self.status.attempts += 1

    def poll(self) -> list[WorkerReport]:
        """Read what the worker sent, enforce the deadlines, restart when due.

        Returns the new reports (oldest first).
        """
        now = self._clock()
        reports: list[WorkerReport] = []
        if self._conn is not None:
            try:
                while self._conn.poll():
                    self._handle(self._conn.recv(), reports)
                    self._last_message = now
            except (EOFError, OSError):
                self._end_worker(self._worker_error or "worker exited", kill=False)
        if self._process is not None and self.status.phase in ("connecting", "running"):
            if not self._process.is_alive():
                self._end_worker(self._worker_error or "worker exited", kill=False)
            elif (self.status.phase == "connecting"
                  and now - self._started_at > self._connect_timeout):
                self._end_worker(
                    f"connect did not finish within {self._connect_timeout:g} s", kill=True
                )
            elif self.status.phase == "running" and now - self._last_message > self._report_timeout:
                self._end_worker(
                    f"worker silent for more than {self._report_timeout:g} s", kill=True
                )
        if self.status.phase == "failed" and not self._closed and now >= self._restart_at:
            self.start()
        return reports

    def _handle(self, message: Any, reports: list[WorkerReport]) -> None:
        kind = message[0]
        if kind == "report":
            self.status.report = message[1]
            reports.append(message[1])
        elif kind == "connected":
            self.status.phase = "running"
            self.status.connected_once = True
            self.status.last_error = ""
        elif kind == "failed":
            self._worker_error = self.status.last_error = str(message[1])

    def _end_worker(self, why: str, kill: bool) -> None:
        self.status.last_error = why
        self.status.history = [*self.status.history[-9:], why]
        if self._process is not None and kill and self._process.is_alive():
            self._process.kill()
            self.status.worker_kills += 1
        self._reap()
        self.status.phase = "failed"
        self.status.report = None
        self._restart_at = self._clock() + self._restart_delay

    def _reap(self) -> None:
        if self._conn is not None:
            self._conn.close()
        if self._process is not None:
            self._process.join(timeout=0.5)  # a killed or exited process is reaped at once
        self._process, self._conn = None, None

    def send_command(self, qd: list[float], stamp: float) -> bool:
        """Forward a command (dropped unless the worker runs and has room)."""
        if self._conn is None or self.status.phase != "running":
            return False
        if not send_nowait(self._conn, ("cmd", qd, stamp)):
            self.status.commands_dropped += 1
            return False
        return True

    def close(self, timeout: float = 2.0) -> None:
        """Ask the worker to stop the arm and exit; kill it after ``timeout`` [s]."""
        self._closed = True
        if self._conn is not None:
            send_nowait(self._conn, ("stop",))
        if self._process is not None:
            self._process.join(timeout=timeout)
            if self._process.is_alive():
                self._process.kill()
                self.status.worker_kills += 1
        self._reap()
        self.status.phase = "stopped"

    @property
    def worker_pid(self) -> int | None:
        """Process id of the current worker (tests, diagnostics)."""
        return None if self._process is None else self._process.pid


__all__ = [
    "ArmFactory",
    "ArmLink",
    "LinkStatus",
    "WorkerReport",
    "run_arm_loop",
    "run_monitor_loop",
    "send_nowait",
    "worker_main",
]
