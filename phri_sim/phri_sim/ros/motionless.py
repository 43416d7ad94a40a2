"""The motionless robot: a scenario played on the simulated world alone, the robot never commanded.

The following metrics compare the controller with this baseline (``phri sim``'s "motionless
robot" column). A robot that is never commanded needs no controller, no skin and no contact
estimation, so no node runs here: the world advances period by period with the bridge's own
pieces — its parameters for these options (:func:`bridge_values`), the simulation they configure,
the scenario's person and shove (:func:`~phri_sim.scenarios.playback.period_steps`) — and the
lock-step run's metrics sample it once per control period, as they sample a run with the
zero-command stub. The two give the same metrics (``test_motionless.py``); this one skips the
skin model, the skin pipeline, contact estimation and every DDS hop, which were ≈ 2/3 of the
baseline's CPU time beside ``phri sim``'s run.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

from phri_common.params import ParamValue
from phri_sim.evaluation.following_metrics import FollowingSeries
from phri_sim.evaluation.metrics import scenario_metrics
from phri_sim.ros.bridge import PARAMS, sensor_faults, shove_of, sim_config
from phri_sim.ros.run_options import MOTIONLESS, RunOptions, run_summary
from phri_sim.scenarios.catalogue import Scenario, start_scenario
from phri_sim.scenarios.playback import period_steps
from phri_sim.world.simulation import Simulation

__all__ = ["MOTIONLESS", "bridge_values", "run_motionless"]

Progress = Callable[[float, float], None]

def bridge_values(scenario: Scenario, options: RunOptions) -> dict[str, ParamValue]:
    """Every simulation-bridge parameter as a lock-step run of ``scenario`` with ``options``
    sets it (the defaults where the options say nothing), checked as the node checks them
    (:class:`~phri_common.params.ParameterValueError` naming the parameter)."""
    given = options.bridge_parameters(scenario)
    return {spec.name: spec.check(given.get(spec.name, spec.default)) for spec in PARAMS}


def run_motionless(scenario: Scenario, options: RunOptions | None = None,
                   progress: Progress | None = None
                   ) -> tuple[dict[str, Any], FollowingSeries | None]:
    """Metrics and following series of ``scenario`` with ``options`` and a robot that is never
    commanded; ``progress(sim time [s], duration [s])`` once per simulated second."""
    options = options or RunOptions()
    values = bridge_values(scenario, options)
    sim = Simulation(sim_config(values))
    script = start_scenario(sim, scenario)
    shove = shove_of(values)
    metrics = scenario_metrics(scenario, sim, options.watched_time(shove.spec))
    period = float(values["control_period"])
    steps = max(1, round(period / sim.dt))
    duration = options.length(scenario)
    start, cpu_start = time.perf_counter(), time.process_time()
    next_report = 1.0
    for _ in range(round(duration / period)):
        for _ in period_steps(sim, script, shove, steps):
            pass
        metrics.sample(sim, sim.watchdog.received(sim.time), {})
        if progress is not None and sim.time >= next_report - 1e-9:
            progress(sim.time, duration)
            next_report += 1.0
    summary = run_summary(
        metrics, scenario, options, controller=MOTIONLESS,
        faults=sensor_faults(values, sim.joint_names[3:]), shove=shove, sim_time=sim.time,
        wall_time=time.perf_counter() - start, cpu_time=time.process_time() - cpu_start)
    return summary, metrics.following_series()
