"""Every sensor fault on the waltz (short form: the hold and the first step, the fault at 5 s, a few
seconds after it) through the real nodes: what the safety layer must do after each fault.

Each fault runs once per module (:func:`runs`); one test checks that the fault really reached the
sensor stream (the wiring), another what the robot did. The behaviour tests of ``skin_blind`` and
``joint_jump`` need the safety layer's controller side (contact-gated desired force, refusing
out-of-range joints). Measured before it (seed 1): blinded waltz — waist 128 N peak, 122 N held
0.5 s (abdomen: 110 N quasi-static), base travel 0.26 m in the 6 s after the fault, never stops;
joint jump — the faulted period commands 0.15 rad/s (the speed limit) instead of zero. With it:
the blinded robot stops 2.0 s after the fault (regain_time) at 65 N, 0.09 m of base travel; the
joint jump costs exactly one zero period.

The faults run on ``waltz_paper`` (the waltz with the paper's literal set, on which the
safety layer was built and measured). On the default waltz set (±0.03 rad q_dance band,
D = 100 N·s/m) the blinded robot's regain motion stops 1.5 s after the fault, but the partner,
dancing on, kept the left shoulder lift and elbow ≈ 1 mrad past the narrow band and the QP's
band constraint (22) pulled them back: the command was never exactly zero. Since the skin's
plausibility checks (contact_estimation.plausibility: a patch reading a constant 0 N is a dead
region) the blinded patch is refused and the controller's contact input goes stale: an exact
zero, band keeping included (:func:`test_blinded_skin_on_the_default_set`). The newer faults
(frozen-but-noisy, half dead, gain, the shove) are in ``test_guard_scenarios.py``.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from typing import Any

import pytest

from phri_sim.evaluation.body_forces import limit_failures
from phri_sim.ros.run_options import RunOptions
from phri_sim.ros.runner import run_scenario

FAULT_SCENARIO = "waltz_paper"
FAULT_TIME = 5.0
PERIOD = 0.01
"""The waltz's control period [s]."""
AFTER = {"skin_blind": 6.0, "skin_stuck": 4.0, "force_spike": 2.0, "joint_jump": 2.0}
"""How long each run goes on after the fault [s]: the blinded robot needs about 5 s to press its
10 N open-loop preload past the abdomen's 110 N (0.05 m/s into the 600 N/m torso), and the safety
layer's regain budget is 2 s."""

Runs = Callable[[str], dict[str, Any]]


@pytest.fixture(scope="module")
def runs() -> Iterator[Runs]:
    """Run a fault on the waltz once (own ROS context) and keep its metrics for the module."""
    done: dict[str, dict[str, Any]] = {}

    def get(fault: str) -> dict[str, Any]:
        if fault not in done:
            done[fault] = run_scenario(FAULT_SCENARIO, RunOptions(
                duration=FAULT_TIME + AFTER[fault], seed=1, fault=fault, fault_time=FAULT_TIME))
        return done[fault]

    yield get


def _person_within_limits(fault: dict[str, Any]) -> None:
    person = fault["forces"]["person"]
    bad = {part: row for part, row in person.items() if not row["ok"]}
    assert not bad, f"person pushed past ISO/TS 15066 after the fault: {bad}"
    assert not limit_failures(fault["forces"])


@pytest.mark.ros
@pytest.mark.parametrize(("fault", "changed"), [
    ("skin_blind", 600), ("skin_stuck", 400), ("force_spike", 1), ("joint_jump", 1),
])
def test_the_fault_reaches_the_sensor_stream_at_its_time(runs: Runs, fault: str,
                                                         changed: int) -> None:
    """Persistent faults change every frame of the touched patch from t_f on (one per period),
    transient ones exactly one message; the after-fault metrics cover the rest of the run."""
    f = runs(fault)["fault"]
    assert f["kind"] == fault and f["fault_time"] == FAULT_TIME
    assert f["first_changed_at"] == pytest.approx(FAULT_TIME, abs=1e-9)
    if changed == 1:
        assert f["messages_changed"] == 1
    else:
        assert f["messages_changed"] >= changed
    assert f["periods"] == pytest.approx(AFTER[fault] / PERIOD, abs=2)


@pytest.mark.ros
def test_blinded_skin_keeps_the_person_safe_and_stops_the_robot(runs: Runs) -> None:
    """A skin that reads nothing is a fault — the robot may move to regain contact
    only within a bounded distance and time (e.g. 0.15 m / 2 s), then stops; the person is never
    pushed past the abdomen's limits."""
    m = runs("skin_blind")
    f = m["fault"]
    _person_within_limits(f)
    assert f["base_travel"] <= 0.2
    assert f["time_to_stop"] is not None and f["time_to_stop"] <= 3.0
    assert m["limit_violations"] == 0


@pytest.mark.ros
def test_stuck_skin_keeps_the_person_safe_and_stops_the_robot(runs: Runs) -> None:
    """A skin replaying its last loaded frame is refused as stuck after ``stuck_timeout``
    (0.5 s); the contact state then goes stale and the controller stops (the lock-step runner
    gives the controller 2 s input timeouts). Without the detector the full waltz presses the
    partner with 486 N."""
    m = runs("skin_stuck")
    f = m["fault"]
    _person_within_limits(f)
    assert f["time_to_stop"] is not None and f["time_to_stop"] <= 3.0
    assert m["limit_violations"] == 0


@pytest.mark.ros
def test_force_spike_commands_resume_within_one_period(runs: Runs) -> None:
    """One taxel at 3e38 N for one frame: at most one period without commands, then the waltz
    goes on (the hold is kept) and nobody is pushed."""
    m = runs("force_spike")
    f = m["fault"]
    assert f["time_to_recover"] is not None and f["time_to_recover"] <= PERIOD + 1e-6
    assert f["zero_command_periods"] <= 1
    _person_within_limits(f)
    assert m["waltz"]["contact_held_share"] >= 0.95
    assert m["limit_violations"] == 0


@pytest.mark.ros
def test_joint_jump_is_refused_for_one_period_then_commands_resume(runs: Runs) -> None:
    """The elbow reads 10 rad (limit ±π) in one joint state: that period's command is zero (bad
    input refused), the next good message commands again."""
    m = runs("joint_jump")
    f = m["fault"]
    assert f["command_zero_at_fault"] is True
    assert f["time_to_recover"] is not None and f["time_to_recover"] <= PERIOD + 1e-6
    assert f["zero_command_periods"] <= 1
    _person_within_limits(f)
    assert m["limit_violations"] == 0


@pytest.mark.ros
def test_blinded_skin_on_the_default_set() -> None:
    """The default waltz set with a blinded skin (module docstring): the person stays within
    limits, the base moves ≤ 0.2 m, and the robot stops with an exact zero command (the band
    keeping included) and stays stopped."""
    m = run_scenario("waltz", RunOptions(duration=FAULT_TIME + AFTER["skin_blind"], seed=1,
                                         fault="skin_blind", fault_time=FAULT_TIME))
    f = m["fault"]
    _person_within_limits(f)
    assert f["base_travel"] <= 0.2
    assert f["base_displacement"] <= 0.2
    assert f["max_command"] <= 0.15
    # Dead region found 1 s after the fault, the lock-step runner's 2 s contact timeout.
    assert f["time_to_stop"] is not None and f["time_to_stop"] <= 3.5
