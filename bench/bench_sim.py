"""Benchmark: simulation speed, and the skin estimation error with and without the driver.

* MuJoCo step time of the full scene with and without the skin model (footprint + sensor model
  on the three patches every step), median and p99, at the model's 2 ms step;
* real-time factor of each scenario through the full stack in lock-step (bridge + contact
  estimation + controller in one process) for each setting — ``fast`` (5 ms physics, 100 Hz
  skin), ``paper`` (2 ms physics, 500 Hz skin) and ``paper+driver`` (the same with the real skin
  driver in the loop: every 500 Hz sample a protocol frame through skin_driver's calibration and
  moving average), ``paper+topics`` (the paper fidelity with the sensor data over their topics
  instead of handed to the nodes, ``sensor_transport="topics"``) — by the wall clock and by the
  process's CPU time (all threads), plus the lock-step period's phases (median and p99 [ms]):
  ``advance`` (physics, skins, sensor messages out), ``sensors`` (until the controller holds
  this period's inputs), ``commands`` (/clock out until the three commands are back);
* ``--skin-errors``: the centring scenario at full length per setting, estimated contact centre
  and force against the physics (mean / max over the scored periods).

The machine's load average is printed with the results: on a shared machine the wall-clock factor
drops with the load, the CPU factor much less. Quote absolute numbers from a quiet machine.

Run: ``.venv/bin/python bench/bench_sim.py [--seconds 5] [--scenarios centring waltz]
[--settings fast paper paper+driver paper+topics] [--skin-errors]``
"""

from __future__ import annotations

import argparse
import os
import time
from typing import Any

import numpy as np

from phri_common.procstat import load_line
from phri_common.testing import isolate_ros_environment
from phri_sim.scenarios.catalogue import SCENARIOS, start_scenario
from phri_sim.world.simulation import Simulation


def step_times(skins: bool, n: int = 2000) -> np.ndarray:
    """Per-step wall time [s] of the centring scene during its press, optionally with the skin
    model evaluated every step (the 500 Hz free-running case)."""
    sc = SCENARIOS["centring"]
    sim = Simulation()
    script = start_scenario(sim, sc)
    out = np.empty(n)
    for i in range(n):
        t0 = time.perf_counter()
        for part, target in script(1.5 + sim.time).items():
            sim.set_target(part, target)
        sim.step()
        if skins:
            sim.skins.forces()
        out[i] = time.perf_counter() - t0
    return out


def _phases(run: Any) -> dict[str, list[float]]:
    """Wrap the run's lock-step phases with timers (same calls as ScenarioRun.step)."""
    phases: dict[str, list[float]] = {"advance": [], "sensors": [], "commands": []}
    bridge = run.bridge
    advance, wait_for = bridge.advance, run.wait_for
    last = [0.0]

    def timed_advance(*args: Any, **kwargs: Any) -> None:
        t0 = time.perf_counter()
        advance(*args, **kwargs)
        last[0] = time.perf_counter()
        phases["advance"].append(last[0] - t0)

    def timed_wait(missing: Any, what: str) -> None:
        t0 = time.perf_counter()
        wait_for(missing, what)
        key = "sensors" if what == "sensor data" else "commands"
        phases[key].append(time.perf_counter() - t0)

    bridge.advance = timed_advance
    run.wait_for = timed_wait
    return phases


SETTINGS: dict[str, dict[str, Any]] = {
    "fast": {"fidelity": "fast"},
    "paper": {"fidelity": "paper"},
    "paper+driver": {"fidelity": "paper", "skin_driver": True},
    "paper+topics": {"fidelity": "paper", "sensor_transport": "topics"},
}
"""Benchmark setting → RunOptions fields."""


def scenario_speed(name: str, seconds: float | None, setting: str = "fast",
                   ) -> tuple[dict[str, Any], dict[str, list[float]]]:
    """Metrics and lock-step phase times of one run (``seconds`` None: full length)."""
    import rclpy
    from rclpy.context import Context

    from phri_sim.ros.run_options import RunOptions
    from phri_sim.ros.runner import ScenarioRun

    context = Context()
    rclpy.init(context=context)
    run = ScenarioRun(SCENARIOS[name], RunOptions(duration=seconds, seed=1, **SETTINGS[setting]),
                      context=context)
    phases = _phases(run)
    try:
        metrics = run.run()
    finally:
        run.close()
        context.try_shutdown()
    phases = {k: v[1:] for k, v in phases.items()}  # the first advance includes discovery
    return metrics, phases


def skin_errors(settings: list[str]) -> None:
    """Centring at full length per setting: estimation error against the physics."""
    print("| setting | centre error mean / max [mm] | force error mean / max [N] | "
          "real-time factor wall / CPU | load |")
    print("|---|---|---|---|---|")
    for setting in settings:
        m, _ = scenario_speed("centring", None, setting)
        link = m["links"]["right_forearm_link"]
        print(f"| {setting} | {link['center_error_mean'] * 1e3:.2f} / "
              f"{link['center_error_max'] * 1e3:.2f} | {link['force_error_mean']:.3f} / "
              f"{link['force_error_max']:.3f} | {m['real_time_factor']:.2f} / "
              f"{m['real_time_factor_cpu']:.2f} | {os.getloadavg()[0]:.2f} |", flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--seconds", type=float, default=5.0, help="sim time per scenario [s]")
    parser.add_argument("--scenarios", nargs="*", default=list(SCENARIOS))
    parser.add_argument("--settings", nargs="*", default=list(SETTINGS), choices=list(SETTINGS))
    parser.add_argument("--skin-errors", action="store_true",
                        help="only the estimation errors of the full centring per setting")
    args = parser.parse_args()
    print(f"before: {load_line()}")
    isolate_ros_environment()
    if args.skin_errors:
        skin_errors(args.settings)
        print(f"after: {load_line()}")
        return
    for skins in (False, True):
        t = step_times(skins) * 1e6
        print(f"step {'with' if skins else 'without'} skins: median {np.median(t):.0f} µs, "
              f"p99 {np.percentile(t, 99):.0f} µs")
    for name in args.scenarios:
        for setting in args.settings:
            m, phases = scenario_speed(name, args.seconds, setting)
            parts = ", ".join(
                f"{k} {np.median(v) * 1e3:.2f}/{np.percentile(v, 99) * 1e3:.2f}"
                for k, v in phases.items() if v
            )
            print(f"{name} [{setting}]: real-time factor {m['real_time_factor']:.2f} wall, "
                  f"{m['real_time_factor_cpu']:.2f} CPU ({args.seconds:.0f} s sim in "
                  f"{m['wall_time']:.1f} s wall); period phases median/p99 [ms]: {parts}; "
                  f"load {os.getloadavg()[0]:.2f}", flush=True)
    print(f"after: {load_line()}")


if __name__ == "__main__":
    main()
