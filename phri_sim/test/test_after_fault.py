"""After-fault metrics (phri_sim.evaluation.metrics.AfterFault) on hand-made series: the definitions
of docs/phri_sim.md, "Fault injection"."""

from __future__ import annotations

import numpy as np
import pytest

from phri_sim.evaluation.metrics import AfterFault

PERIOD = 0.01


def _q(x: float = 0.0, y: float = 0.0, elbow: float = 0.0) -> np.ndarray:
    q = np.zeros(15)
    q[0], q[1], q[5] = x, y, elbow
    return q


def _cmd(v: float) -> np.ndarray:
    c = np.zeros(15)
    c[0] = v
    return c


def test_travel_and_excursion_count_from_the_fault_on() -> None:
    after = AfterFault(5.0)
    # The base goes 0.3 m along x and 0.4 m back along y; the elbow swings 0.2 then -0.1.
    for t, q in ((5.0, _q()), (5.01, _q(0.3, 0.0, 0.2)), (5.02, _q(0.3, 0.4, -0.1))):
        after.sample(t, q, _cmd(0.1))
    s = after.summary()
    assert s["base_travel"] == pytest.approx(0.7)
    assert s["base_displacement"] == pytest.approx(0.5)
    assert s["max_joint_excursion"] == pytest.approx(0.2)
    assert s["periods"] == 3 and s["max_command"] == pytest.approx(0.1)


def test_one_zero_period_then_commands_resume() -> None:
    after = AfterFault(5.0)
    for k, v in enumerate([0.0, 0.05, 0.05, 0.05]):
        after.sample(5.0 + k * PERIOD, _q(), _cmd(v))
    s = after.summary()
    assert s["command_zero_at_fault"] is True
    assert s["time_to_zero_command"] == pytest.approx(0.0)
    assert s["time_to_recover"] == pytest.approx(PERIOD)
    assert s["zero_command_periods"] == 1
    assert s["time_to_stop"] is None  # commanding at the end


def test_a_wedged_controller_never_recovers_and_a_stopped_one_is_timed() -> None:
    wedged = AfterFault(5.0)
    for k, v in enumerate([0.05, 0.0, 0.0, 0.0]):
        wedged.sample(5.0 + k * PERIOD, _q(), _cmd(v))
    s = wedged.summary()
    assert s["time_to_recover"] is None
    assert s["time_to_stop"] == pytest.approx(PERIOD)
    assert s["command_zero_at_fault"] is False


def test_never_interrupted_recovers_at_once_and_standstill_needs_every_joint_still() -> None:
    after = AfterFault(5.0)
    rates = [np.full(15, 0.01), np.zeros(15), np.full(15, 0.002), np.zeros(15), np.zeros(15)]
    for k, qd in enumerate(rates):
        after.sample(5.0 + k * PERIOD, _q(), _cmd(0.05), qd)
    s = after.summary()
    assert s["time_to_recover"] == 0.0 and s["time_to_zero_command"] is None
    assert s["time_to_standstill"] == pytest.approx(3 * PERIOD)
