"""A simulated UR arm behind :class:`~phri_hardware.ur_arm.ArmInterface` (tests and dry runs).

:class:`FakeArm` behaves like a UR controller running ur_rtde's control script, as far as the
bridge can tell: ``speedJ`` ramps the joint speeds towards the target at the given acceleration
and the positions integrate them; ``speedStop`` ramps to zero; a protective stop (scripted with
:class:`FakeArmSpec`) halts the arm at once and ends the control script (as on the robot, so the
bridge has to restart it); the RTDE watchdog halts the arm and ends the script when no call
arrives at its minimum frequency.

For tests it can also misbehave the way a real host can: connect after a delay, fail to
connect, or hang in connect *holding the GIL* (as ur_rtde's constructor does against a host that
accepts and never answers) — the libc ``sleep`` is called through ``ctypes.PyDLL``, which does
not release the GIL. With ``log_path`` every call is appended to a JSON-lines file (time, call,
arguments, protective stop flag) that a test in another process can read. A protective stop is
scripted in time after connect, or lasts while a file exists (a test in another process starts
and ends it on cue). A test that drives the arm itself passes a fake ``clock``.
"""

from __future__ import annotations

import ctypes
import json
import math
import os
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

from phri_hardware.ur_arm import ArmState, RobotMode, SafetyMode

DEFAULT_Q: tuple[float, ...] = (0.0, -1.5708, 1.5708, -1.5708, -1.5708, 0.0)
"""Joint positions of the fake arm at start [rad] (a folded, harmless pose)."""


@dataclass(frozen=True)
class FakeArmSpec:
    """Picklable factory and script of a :class:`FakeArm` (times after connect [s]).

    Attributes:
        connect_delay: seconds connect takes.
        connect_hangs: connect never returns and holds the GIL meanwhile.
        connect_fails: connect raises ``ConnectionError``.
        initial_q: start positions [rad].
        protective_stop_at: start of a protective stop (None = never).
        protective_stop_for: its duration [s].
        protective_stop_file: a protective stop also lasts while this file exists ("" = no
            file).
        robot_mode, safety_mode: modes while no protective stop is scripted.
        speed_scaling: the reported speed scaling, 0–1 (the pendant's slider; the fake arm
            executes speedJ scaled by it, as the robot does).
        log_path: JSON-lines call log ("" = none).
    """

    connect_delay: float = 0.0
    connect_hangs: bool = False
    connect_fails: bool = False
    initial_q: tuple[float, ...] = DEFAULT_Q
    protective_stop_at: float | None = None
    protective_stop_for: float = 1.0
    protective_stop_file: str = ""
    robot_mode: int = RobotMode.RUNNING
    safety_mode: int = SafetyMode.NORMAL
    speed_scaling: float = 1.0
    log_path: str = ""

    def __call__(self) -> FakeArm:
        return FakeArm(self)


def _hang_holding_gil() -> None:
    libc = ctypes.PyDLL(None)  # PyDLL calls keep the GIL, like a blocking C++ constructor
    while True:
        libc.sleep(3600)


class FakeArm:
    """Kinematic UR stand-in (see the module docstring).

    ``clock`` [s] is the arm's monotonic time (its motion, the scripted protective stop and the
    watchdog follow it). :attr:`speed_j_while_protective_stopped` counts speedJ calls that came
    after the last state read showed a protective stop (the bridge knew of it); the log's
    ``pstop`` flag is that state's too.
    """

    def __init__(self, spec: FakeArmSpec | None = None,
                 clock: Callable[[], float] = time.monotonic) -> None:
        self.spec = spec or FakeArmSpec()
        self._clock = clock
        self.q = list(self.spec.initial_q)
        self.qd = [0.0] * 6
        self._target = [0.0] * 6
        self._accel = 1.0
        self._connected = False
        self._program_running = False
        self._connected_at = 0.0
        self._last_update = 0.0
        self._last_input = 0.0
        self._watchdog_period = 0.0
        self._was_pstopped = False
        self._reported_pstop = False  # the protective stop flag of the state last read
        self.calls: list[tuple[str, tuple[Any, ...]]] = []
        self.speed_j_while_protective_stopped = 0

    # -- simulation ---------------------------------------------------------------------------
    def _protective_stopped(self, now: float) -> bool:
        if not self._connected:
            return False
        if self.spec.protective_stop_file and os.path.exists(self.spec.protective_stop_file):
            return True
        start = self.spec.protective_stop_at
        if start is None:
            return False
        t = now - self._connected_at
        return start <= t < start + self.spec.protective_stop_for

    def _advance(self) -> None:
        now = self._clock()
        dt = max(0.0, now - self._last_update)
        self._last_update = now
        pstop = self._protective_stopped(now)
        if pstop and not self._was_pstopped:
            self._program_running = False  # a protective stop ends the control script
        self._was_pstopped = pstop
        if (self._watchdog_period > 0.0 and self._program_running
                and now - self._last_input > self._watchdog_period):
            self._program_running = False  # RTDE watchdog: the script stops the robot
        if pstop or not self._program_running:
            self.qd = [0.0] * 6
            self._target = [0.0] * 6
            return
        step = self._accel * dt
        for j in range(6):
            dv = self._target[j] - self.qd[j]
            self.qd[j] += max(-step, min(step, dv))
            self.q[j] += self.qd[j] * dt

    def _log(self, call: str, *args: Any) -> None:
        self.calls.append((call, args))
        if self.spec.log_path:
            entry = {"t": self._clock(), "call": call,
                     "args": [list(a) if isinstance(a, (list, tuple)) else a for a in args],
                     "pstop": self._reported_pstop}
            with open(self.spec.log_path, "a", encoding="utf-8") as f:
                f.write(json.dumps(entry) + "\n")

    def _input(self) -> None:
        self._last_input = self._clock()

    # -- ArmInterface -------------------------------------------------------------------------
    def connect(self) -> None:
        self._log("connect")
        if self.spec.connect_hangs:
            _hang_holding_gil()
        if self.spec.connect_delay > 0.0:
            time.sleep(self.spec.connect_delay)
        if self.spec.connect_fails:
            raise ConnectionError("fake arm: connection refused")
        self._connected = True
        self._program_running = True
        self._connected_at = self._last_update = self._last_input = self._clock()

    def read_state(self) -> ArmState:
        self._advance()
        pstop = self._reported_pstop = self._protective_stopped(self._clock())
        return ArmState(
            q=tuple(self.q), qd=tuple(self.qd),
            robot_mode=self.spec.robot_mode if self._connected else RobotMode.DISCONNECTED,
            safety_mode=SafetyMode.PROTECTIVE_STOP if pstop else self.spec.safety_mode,
            protective_stopped=pstop, emergency_stopped=False,
            program_running=self._program_running, connected=self._connected,
            speed_scaling=self.spec.speed_scaling if self._connected else 0.0,
        )

    def speed_j(self, qd: Sequence[float], acceleration: float, time: float) -> bool:
        del time
        self._log("speedJ", list(qd), acceleration)
        self._advance()
        self._input()
        if self._reported_pstop:
            self.speed_j_while_protective_stopped += 1
        if self._protective_stopped(self._last_update):
            return False
        if not self._program_running:
            return False
        if len(qd) != 6 or not all(math.isfinite(v) for v in qd):
            return False
        self._target = [float(v) * self.spec.speed_scaling for v in qd]  # the slider scales it
        self._accel = acceleration
        return True

    def speed_stop(self, deceleration: float) -> bool:
        self._log("speedStop", deceleration)
        self._advance()
        self._input()
        self._target = [0.0] * 6
        self._accel = deceleration
        return True

    def set_watchdog(self, min_frequency: float) -> bool:
        self._log("setWatchdog", min_frequency)
        self._watchdog_period = 1.0 / min_frequency if min_frequency > 0.0 else 0.0
        self._input()
        return True

    def kick_watchdog(self) -> bool:
        self._input()  # not logged: it happens every idle period
        return True

    def restart_program(self) -> bool:
        self._log("reuploadScript")
        if self._protective_stopped(self._clock()):
            return False
        self._program_running = True
        self._input()
        return True

    def disconnect(self) -> None:
        self._log("disconnect")
        self._connected = False
        self._program_running = False


__all__ = ["DEFAULT_Q", "FakeArm", "FakeArmSpec"]
