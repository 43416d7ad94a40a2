"""Lock-step waits on simulated progress, not on the host's speed (phri_sim.ros.lockstep).

The unit tests drive :class:`LockStep` with a fake executor and a fake wall clock whose every
read is a minute later (a host far slower than any fixed timeout): a phase whose messages trickle
in, or that stalls and then proceeds, completes; a node that is destroyed, taken off the executor
or failed ends the wait at once; a silent one after the stall limit. The integration tests run
the real nodes on such a clock (the same run, number for number) and take the controller off a
running run (a clear error)."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import Any

import pytest

from contact_estimation.frame_checks import MAX_TAXEL_FORCE_RANGE
from phri_sim.ros.lockstep import STALL_LIMIT, LockStep, LockStepError
from phri_sim.ros.run_options import RunOptions
from phri_sim.ros.runner import ScenarioRun
from phri_sim.scenarios.catalogue import scenario_named

MINUTE = 60.0
EXPECTED = ["contacts/left_forearm_link", "contacts/right_forearm_link", "/odom"]
TIMING = {"wall_time", "real_time_factor", "cpu_time", "real_time_factor_cpu"}


class FakeClock:
    """A wall clock that moves ``step`` [s] on every read."""

    def __init__(self, step: float) -> None:
        self.step, self.now = step, 0.0

    def __call__(self) -> float:
        self.now += self.step
        return self.now


class FakeNode:
    def __init__(self, name: str) -> None:
        self.name, self.destroyed, self.fatal_error = name, False, None

    def get_name(self) -> str:
        if self.destroyed:
            raise RuntimeError("cannot use Destroyable because destruction was requested")
        return self.name


class FakeExecutor:
    """Calls ``on_spin(n)`` on its n-th spin."""

    def __init__(self, nodes: list[FakeNode], on_spin: Callable[[int], None]) -> None:
        self.nodes, self.on_spin, self.spins = nodes, on_spin, 0

    def spin_once(self, timeout_sec: float) -> None:
        self.spins += 1
        self.on_spin(self.spins)

    def get_nodes(self) -> list[FakeNode]:
        return list(self.nodes)


class FakeContext:
    def __init__(self) -> None:
        self.up = True

    def ok(self) -> bool:
        return self.up


def _lockstep(on_spin: Callable[[int], None], nodes: list[FakeNode] | None = None
              ) -> tuple[LockStep, FakeExecutor, list[str]]:
    nodes = nodes if nodes is not None else [FakeNode("controller")]
    executor = FakeExecutor(nodes, on_spin)
    warnings: list[str] = []
    return LockStep(executor, FakeContext(), nodes, warn=warnings.append,
                    clock=FakeClock(MINUTE)), executor, warnings


def test_messages_that_trickle_in_on_a_slow_host_are_waited_for() -> None:
    """One expected message every third spin, a minute per spin: done when the last arrives."""
    arrived: list[int] = []
    lockstep, executor, _ = _lockstep(lambda n: arrived.append(n) if n % 3 == 0 else None)
    lockstep.wait(lambda: EXPECTED[len(arrived):], "sensor data", 1.0)
    assert executor.spins == 9 and len(arrived) == 3


def test_a_stalled_phase_that_proceeds_is_not_an_error() -> None:
    """Nothing for eight minutes (the warning names what is missing), then everything."""
    done = [False]
    spins_before = int(0.9 * STALL_LIMIT / MINUTE)

    def on_spin(n: int) -> None:
        done[0] = n > spins_before

    lockstep, executor, warnings = _lockstep(on_spin)
    lockstep.wait(lambda: [] if done[0] else EXPECTED, "controller commands", 2.5)
    assert executor.spins == spins_before + 1
    assert len(warnings) == 1
    assert "controller commands" in warnings[0] and EXPECTED[0] in warnings[0]


def test_a_silent_phase_ends_after_the_stall_limit_naming_what_is_missing() -> None:
    lockstep, executor, _ = _lockstep(lambda n: None)
    with pytest.raises(LockStepError) as err:
        lockstep.wait(lambda: EXPECTED, "sensor data", 1.25)
    assert executor.spins * MINUTE > STALL_LIMIT
    message = str(err.value)
    assert "sensor data" in message and "1.250" in message
    assert all(topic in message for topic in EXPECTED)


@pytest.mark.parametrize("death", ["destroyed", "off the executor", "failed", "context down"])
def test_a_dead_node_ends_the_wait_at_once(death: str) -> None:
    node = FakeNode("wholebody_controller")
    nodes = [FakeNode("phri_sim"), node]
    holder: dict[str, Any] = {}

    def on_spin(n: int) -> None:
        if n == 2:
            if death == "destroyed":
                node.destroyed = True
            elif death == "off the executor":
                holder["executor"].nodes.remove(node)
            elif death == "failed":
                node.fatal_error = RuntimeError("control loop")  # type: ignore[assignment]
            else:
                holder["context"].up = False

    lockstep, executor, _ = _lockstep(on_spin, nodes)
    holder["executor"], holder["context"] = executor, lockstep.context
    with pytest.raises(LockStepError) as err:
        lockstep.wait(lambda: EXPECTED, "sensor data", 3.0)
    assert executor.spins == 2
    message = str(err.value)
    assert "sensor data" in message and "3.000" in message
    if death != "context down":
        assert "wholebody_controller" in message


def _outcome(metrics: dict[str, Any]) -> dict[str, Any]:
    return {k: v for k, v in metrics.items() if k not in TIMING}


@pytest.mark.ros
def test_a_host_slower_than_any_fixed_timeout_gives_the_same_run(ros_context: Any) -> None:
    """The same run with a wall clock that moves a minute whenever the runner reads it: every
    phase that needs more than one spin looks twelve times longer than the former 5 s timeout;
    the run completes and its metrics equal the undisturbed run's."""
    scenario, options = scenario_named("centring"), RunOptions(duration=1.2, seed=2)
    outcomes = []
    for slow in (False, True):
        run = ScenarioRun(scenario, options, context=ros_context)
        if slow:
            run.lockstep.clock = FakeClock(MINUTE)
        try:
            outcomes.append(_outcome(run.run()))
        finally:
            run.close()
    assert outcomes[0]["duration"] == pytest.approx(1.2)
    assert outcomes[1] == outcomes[0]


@pytest.mark.ros
def test_a_controller_taken_off_the_run_is_reported(ros_context: Any) -> None:
    """The controller leaves the executor after 1 s of sim time: the next phase ends with an
    error naming it (the silent-node bound would name only the missing commands)."""
    run = ScenarioRun(scenario_named("centring"), RunOptions(duration=2.0),
                      context=ros_context)
    run.lockstep.clock = FakeClock(MINUTE)  # a missed detection fails fast, not after 10 min
    run.progress = lambda t, total: run.executor.remove_node(run.controller)
    try:
        with pytest.raises(LockStepError, match="wholebody_controller is no longer spun"):
            run.run()
        assert run.bridge.sim.time == pytest.approx(1.0, abs=0.011)
    finally:
        run.close()


@pytest.mark.ros
@pytest.mark.parametrize("controller", ["node", "stub"])
def test_a_frame_the_estimation_refuses_is_not_waited_for(ros_context: Any,
                                                          controller: str) -> None:
    """Every touched frame beyond a tiny rated range is refused as corrupted, so the touched
    link gets no contact state for its period: the lock-step goes on without it (on a clock
    that moves a minute per read, a phase that waited for it would end at the stall limit)."""
    centring = scenario_named("centring")
    scenario = dataclasses.replace(centring, estimation_parameters={
        **centring.estimation_parameters, "max_taxel_force": MAX_TAXEL_FORCE_RANGE[0]})
    run = ScenarioRun(scenario, RunOptions(duration=2.0, controller=controller),
                      context=ros_context)
    run.lockstep.clock = FakeClock(MINUTE)
    try:
        run.run()
        assert run.bridge.sim.time == pytest.approx(2.0, abs=0.011)
        assert sum(run.estimation.refused_frames.values()) > 0  # type: ignore[attr-defined]
    finally:
        run.close()
