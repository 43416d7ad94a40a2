"""The worker loop drives a simulated arm: commands at rate, staleness, protective stop, stop."""

from __future__ import annotations

import multiprocessing
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager

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
QD = [0.1, -0.05, 0.0, 0.0, 0.0, 0.2]


@contextmanager
def running_loop(arm: FakeArm, config: BridgeConfig) -> Iterator[tuple[object, list]]:
    parent, child = multiprocessing.Pipe(duplex=True)
    result: list[str] = []
    thread = threading.Thread(
        target=lambda: result.append(run_arm_loop(arm, config, child, watchdog_frequency=2.0)),
        daemon=True,
    )
    thread.start()
    try:
        yield parent, result
    finally:
        send_nowait(parent, ("stop",))
        thread.join(timeout=5.0)
        assert not thread.is_alive()


def feed(conn: object, qd: list[float], duration: float) -> list[WorkerReport]:
    """Send ``qd`` at the control rate for ``duration`` [s]; collect the worker's reports."""
    reports: list[WorkerReport] = []
    end = time.monotonic() + duration
    while time.monotonic() < end:
        send_nowait(conn, ("cmd", qd, time.monotonic()))  # type: ignore[arg-type]
        while conn.poll():  # type: ignore[attr-defined]
            msg = conn.recv()  # type: ignore[attr-defined]
            if msg[0] == "report":
                reports.append(msg[1])
        time.sleep(1.0 / RATE)
    return reports


def count(arm: FakeArm, call: str) -> int:
    return sum(1 for name, _ in arm.calls if name == call)


def test_commands_reach_the_arm_at_rate_and_move_it() -> None:
    arm = FakeArm(FakeArmSpec())
    config = BridgeConfig(rate_hz=RATE, acceleration=40.0, command_timeout=0.2)
    with running_loop(arm, config) as (conn, _):
        feed(conn, [0.0] * 6, 0.2)  # arming command
        q0 = list(arm.q)
        t0 = time.monotonic()
        n0 = count(arm, "speedJ")
        reports = feed(conn, QD, 1.0)
        elapsed = time.monotonic() - t0
        q1 = list(arm.q)
        sent = count(arm, "speedJ") - n0
    assert sent >= 0.6 * RATE * elapsed  # loose: the machine is shared
    assert reports and reports[-1].armed and reports[-1].moving
    # positions integrate the commanded speeds (joint 5 moves 0.2 rad/s, joint 2 stays)
    for j in (0, 1, 5):
        assert abs((q1[j] - q0[j]) - QD[j] * elapsed) < 0.25 * abs(QD[j]) * elapsed + 0.01
    assert abs(q1[2] - q0[2]) < 1e-9
    assert arm.calls[-2][0] == "speedStop" and arm.calls[-1][0] == "disconnect"


def test_stale_commands_stop_the_arm() -> None:
    arm = FakeArm(FakeArmSpec())
    config = BridgeConfig(rate_hz=RATE, command_timeout=0.1, acceleration=40.0)
    with running_loop(arm, config) as (conn, _):
        feed(conn, [0.0] * 6, 0.1)
        feed(conn, QD, 0.3)
        stops_before = count(arm, "speedStop")
        time.sleep(0.5)  # the stream stops
        stops_after = count(arm, "speedStop")
        assert stops_after == stops_before + 1
        assert arm.calls[-1][0] == "speedStop"  # and no speedJ since
        assert max(abs(v) for v in arm.qd) < 1e-9  # the simulated arm is still


def test_protective_stop_sends_nothing_while_it_lasts_and_needs_rearming() -> None:
    arm = FakeArm(FakeArmSpec(protective_stop_at=0.4, protective_stop_for=0.6))
    config = BridgeConfig(rate_hz=RATE, command_timeout=0.1)
    with running_loop(arm, config) as (conn, _):
        feed(conn, [0.0] * 6, 0.1)
        reports = feed(conn, QD, 1.5)  # runs through the protective stop, same command
        during = [r for r in reports if r.state.protective_stopped]
        assert during and all(r.hold_reason == "protective stop" for r in during)
        after = reports[-1]
        assert not after.state.protective_stopped and not after.armed  # no jump back to QD
        assert count(arm, "reuploadScript") >= 1
        feed(conn, [0.0] * 6, 0.2)
        reports = feed(conn, QD, 0.2)
        assert reports[-1].moving and reports[-1].armed
    # what the robot saw: no speedJ while protectively stopped, one speedStop at its onset
    assert arm.speed_j_while_protective_stopped == 0
    assert during[-1].counters.fault_stops == 1


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
    arm = FakeArm(FakeArmSpec())
    parent, child = multiprocessing.Pipe(duplex=True)
    result: list[str] = []
    thread = threading.Thread(
        target=lambda: result.append(run_monitor_loop(arm, BridgeConfig(rate_hz=RATE), child)),
        daemon=True,
    )
    thread.start()
    try:
        reports = feed(parent, QD, 0.5)  # commands arrive and are discarded
    finally:
        send_nowait(parent, ("stop",))
        thread.join(timeout=5.0)
    assert result == ["stop requested"]
    assert len(reports) >= 0.5 * RATE * 0.5
    assert all(r.hold_reason == MONITOR_HOLD and r.action == "none" for r in reports)
    assert reports[-1].state.q == arm.spec.initial_q  # the arm never moved
    assert [name for name, _ in arm.calls] == ["connect", "disconnect"]  # no speedJ/Stop/watchdog


def test_bridge_settings_refusal_names_the_setting_value_and_range() -> None:
    with pytest.raises(ValueError, match=r"rate_hz refused value 0.0: allowed \(0, inf\)"):
        BridgeConfig(rate_hz=0.0)
    with pytest.raises(ValueError, match=r"velocity_cap refused value nan: allowed \[0, inf\)"):
        BridgeConfig(velocity_cap=float("nan"))
