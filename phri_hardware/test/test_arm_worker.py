"""The worker loop drives a simulated arm: commands every cycle, staleness, protective stop, stop.

The loop, the arm and the node's side of the pipe share one fake clock (:class:`Lockstep`):
time moves only when the loop sleeps to its next cycle, so every assertion is about one precise
cycle, whatever the machine's load. Timeouts are chosen off the cycle grid (0.105 s at 10 ms
cycles) so that no comparison falls on a rounding boundary.
"""

from __future__ import annotations

import multiprocessing
from collections.abc import Sequence

import pytest

from phri_hardware.arm_worker import (
    MONITOR_HOLD,
    WorkerReport,
    run_arm_loop,
    run_monitor_loop,
    send_nowait,
)
from phri_hardware.fake_arm import FakeArm, FakeArmSpec
from phri_hardware.ur_arm import BridgeConfig

RATE = 100.0
PERIOD = 1.0 / RATE
QD = [0.1, -0.05, 0.0, 0.0, 0.0, 0.2]
ZERO = [0.0] * 6
Step = list[float] | None
"""What the node sends before one cycle: a command (stamped with the cycle's time) or nothing."""


class Lockstep:
    """Fake monotonic time [s] for the worker loop and the arm, and the node's side of the pipe,
    acted out in the loop's ``sleep``: before cycle k the node sends ``steps[k]``; after the last
    step it asks the loop to stop (so the loop runs ``len(steps)`` cycles)."""

    def __init__(self, steps: Sequence[Step]) -> None:
        self.now = 100.0
        self.steps = list(steps)
        self.node, self.worker = multiprocessing.Pipe(duplex=True)
        self.cycle = 0  # the next cycle
        self.times: list[float] = []  # of each cycle
        self.reports: list[WorkerReport] = []
        self._calls_at: list[int] = []  # len(arm.calls) when each cycle began
        self.arm = FakeArm(clock=self.clock)  # replaced by run()'s

    def clock(self) -> float:
        return self.now

    def sleep(self, seconds: float) -> None:
        self._collect()
        self.now += seconds
        self._before_cycle()

    def run(self, arm: FakeArm, config: BridgeConfig, monitor: bool = False) -> str:
        """Run the loop (in this thread) until the steps are used up; why it ended."""
        self.arm = arm
        self._before_cycle()  # cycle 0 starts at once after connect (connect takes no time)
        if monitor:
            why = run_monitor_loop(arm, config, self.worker, clock=self.clock, sleep=self.sleep)
        else:
            why = run_arm_loop(arm, config, self.worker, watchdog_frequency=2.0,
                               clock=self.clock, sleep=self.sleep)
        self._collect()
        return why

    def calls(self, cycle: int) -> list[tuple[str, tuple[object, ...]]]:
        """The arm calls of ``cycle`` (connect and the watchdog set-up left out)."""
        end = self._calls_at[cycle + 1] if cycle + 1 < len(self._calls_at) else None
        return [c for c in self.arm.calls[self._calls_at[cycle]:end]
                if c[0] not in ("connect", "setWatchdog")]

    def names(self, cycle: int) -> list[str]:
        return [name for name, _ in self.calls(cycle)]

    def _before_cycle(self) -> None:
        self._calls_at.append(len(self.arm.calls))
        self.times.append(self.now)
        if self.cycle < len(self.steps):
            qd = self.steps[self.cycle]
            if qd is not None:
                assert send_nowait(self.node, ("cmd", qd, self.now))
        else:
            assert send_nowait(self.node, ("stop",))
        self.cycle += 1

    def _collect(self) -> None:
        while self.node.poll():
            message = self.node.recv()
            if message[0] == "report":
                self.reports.append(message[1])


def fake_arm(lockstep: Lockstep, spec: FakeArmSpec | None = None) -> FakeArm:
    return FakeArm(spec or FakeArmSpec(), clock=lockstep.clock)


def test_every_cycle_sends_the_newest_command_and_the_arm_integrates_it() -> None:
    steps: list[Step] = [ZERO] * 20 + [QD] * 100
    run = Lockstep(steps)
    arm = fake_arm(run)
    config = BridgeConfig(rate_hz=RATE, acceleration=40.0, command_timeout=0.105)
    assert run.run(arm, config) == "stop requested"
    # One speedJ per cycle (100 per second of the loop's clock), each with its cycle's command.
    for k, qd in enumerate(steps):
        assert run.calls(k) == [("speedJ", (qd, 40.0))], k
    assert run.times[1:len(steps)] == pytest.approx(
        [run.times[0] + PERIOD * k for k in range(1, len(steps))])
    assert len(run.reports) == len(steps)
    assert run.reports[-1].armed and run.reports[-1].moving
    # Positions integrate the commanded speeds over the 100 cycles of QD (1 s): within one
    # cycle of ramp-up at 40 rad/s²; joint 2 is commanded 0 and never moves.
    q0, q1 = run.reports[19].state.q, run.reports[-1].state.q
    for j in (0, 1, 5):
        assert abs((q1[j] - q0[j]) - QD[j] * 100 * PERIOD) <= abs(QD[j]) * PERIOD + 1e-12, j
    assert q1[2] == q0[2]
    assert [name for name, _ in arm.calls[-2:]] == ["speedStop", "disconnect"]


def test_stale_commands_stop_the_arm_at_the_first_cycle_past_the_timeout() -> None:
    steps: list[Step] = [ZERO] * 10 + [QD] * 30 + [None] * 30  # the stream stops after 39
    run = Lockstep(steps)
    arm = fake_arm(run)
    config = BridgeConfig(rate_hz=RATE, acceleration=40.0, command_timeout=0.105)
    run.run(arm, config)
    # 0.105 s after the last command (cycle 39): cycles 40…49 (≤ 0.1 s) repeat it, cycle 50
    # (0.11 s) stops the arm, and nothing is sent after that (only the watchdog is kicked).
    assert all(run.names(k) == ["speedJ"] for k in range(40, 50))
    assert run.names(50) == ["speedStop"]
    assert all(run.names(k) == [] for k in range(51, 70))
    assert [r.hold_reason for r in run.reports[49:51]] == ["", "command stale"]
    assert not run.reports[-1].moving and run.reports[-1].counters.stale_stops == 1
    assert max(abs(v) for v in run.reports[-1].state.qd) == 0.0  # the simulated arm is still


def test_protective_stop_sends_nothing_while_it_lasts_and_needs_rearming() -> None:
    # The protective stop lasts from 0.405 s to 1.005 s after connect: cycles 41…100.
    steps: list[Step] = [ZERO] * 10 + [QD] * 110 + [ZERO] * 20 + [QD] * 20
    run = Lockstep(steps)
    arm = fake_arm(run, FakeArmSpec(protective_stop_at=0.405, protective_stop_for=0.6))
    config = BridgeConfig(rate_hz=RATE, command_timeout=0.105)
    run.run(arm, config)
    stopped = [k for k, r in enumerate(run.reports) if r.state.protective_stopped]
    assert stopped == list(range(41, 101))
    assert all(run.reports[k].hold_reason == "protective stop" for k in stopped)
    # What the robot saw: one speedStop at the onset, nothing else while it lasted.
    assert run.names(41) == ["speedStop"]
    assert all(run.names(k) == [] for k in range(42, 101))
    assert arm.speed_j_while_protective_stopped == 0
    assert run.reports[100].counters.fault_stops == 1
    # Released (cycle 101): the control script is restarted; the command is still QD, so the
    # bridge stays disarmed (no jump back to QD) until the zero commands from cycle 120 on.
    assert run.names(101) == ["reuploadScript"]
    assert all("speedJ" not in run.names(k) for k in range(101, 120))
    assert not run.reports[119].armed and "disarmed" in run.reports[119].hold_reason
    assert run.names(120) == ["speedJ"] and run.reports[120].armed
    assert run.reports[-1].moving and run.calls(len(steps) - 1) == [("speedJ", (QD, 2.0))]


def test_refused_connect_is_reported() -> None:
    parent, child = multiprocessing.Pipe(duplex=True)
    why = run_arm_loop(FakeArm(FakeArmSpec(connect_fails=True)), BridgeConfig(), child, 10.0)
    assert why == "connect failed"
    messages = []
    while parent.poll():
        messages.append(parent.recv())
    assert messages[0] == ("connecting",)
    assert messages[-1][0] == "failed" and "refused" in messages[-1][1]


def test_monitor_loop_never_commands_the_arm() -> None:
    steps: list[Step] = [QD] * 50  # commands arrive and are discarded
    run = Lockstep(steps)
    arm = fake_arm(run)
    assert run.run(arm, BridgeConfig(rate_hz=RATE), monitor=True) == "stop requested"
    assert len(run.reports) == len(steps)  # one report per cycle
    assert all(r.hold_reason == MONITOR_HOLD and r.action == "none" for r in run.reports)
    assert run.reports[-1].state.q == arm.spec.initial_q  # the arm never moved
    assert [name for name, _ in arm.calls] == ["connect", "disconnect"]  # no speedJ/Stop/watchdog


def test_bridge_settings_refusal_names_the_setting_value_and_range() -> None:
    with pytest.raises(ValueError, match=r"rate_hz refused value 0.0: allowed \(0, inf\)"):
        BridgeConfig(rate_hz=0.0)
    with pytest.raises(ValueError, match=r"velocity_cap refused value nan: allowed \[0, inf\)"):
        BridgeConfig(velocity_cap=float("nan"))
