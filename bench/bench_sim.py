"""Benchmark: simulation speed.

* MuJoCo step time of the full scene with and without the skin model (footprint + noise on the
  three patches every step), median and p99, at the model's 2 ms step;
* real-time factor of each scenario through the full stack in lock-step (bridge + contact
  estimation + controller in one process), by the wall clock and by the process's CPU time
  (all threads), plus the lock-step period's phases (median and p99 [ms]): ``advance`` (physics,
  skins, sensor messages out), ``sensors`` (until the controller holds this period's inputs),
  ``commands`` (/clock out until the three commands are back).

The machine's load average is printed with the results: on a shared machine the wall-clock factor
drops with the load, the CPU factor much less. Quote absolute numbers from a quiet machine.

Run: ``.venv/bin/python bench/bench_sim.py [--seconds 5] [--scenarios centring waltz]``
"""

from __future__ import annotations

import argparse
import os
import time
from typing import Any

import numpy as np

from phri_common.procstat import load_line
from phri_common.testing import isolate_ros_environment
from phri_sim.scenarios import SCENARIOS, start_scenario
from phri_sim.sim import Simulation


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
    advance, spin_until = bridge.advance, run.spin_until
    last = [0.0]

    def timed_advance(*args: Any, **kwargs: Any) -> None:
        t0 = time.perf_counter()
        advance(*args, **kwargs)
        last[0] = time.perf_counter()
        phases["advance"].append(last[0] - t0)

    def timed_spin(condition: Any, what: str) -> None:
        t0 = time.perf_counter()
        spin_until(condition, what)
        key = "sensors" if what == "sensor data" else "commands"
        phases[key].append(time.perf_counter() - t0)

    bridge.advance = timed_advance
    run.spin_until = timed_spin
    return phases


def scenario_speed(name: str, seconds: float) -> tuple[dict[str, Any], dict[str, list[float]]]:
    import rclpy
    from rclpy.context import Context

    from phri_sim.runner import ScenarioRun

    context = Context()
    rclpy.init(context=context)
    run = ScenarioRun(name, context=context, duration=seconds)
    phases = _phases(run)
    try:
        metrics = run.run()
    finally:
        run.close()
        context.try_shutdown()
    phases = {k: v[1:] for k, v in phases.items()}  # the first advance includes discovery
    return metrics, phases


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--seconds", type=float, default=5.0, help="sim time per scenario [s]")
    parser.add_argument("--scenarios", nargs="*", default=list(SCENARIOS))
    args = parser.parse_args()
    print(f"before: {load_line()}")
    for skins in (False, True):
        t = step_times(skins) * 1e6
        print(f"step {'with' if skins else 'without'} skins: median {np.median(t):.0f} µs, "
              f"p99 {np.percentile(t, 99):.0f} µs")
    isolate_ros_environment()
    for name in args.scenarios:
        m, phases = scenario_speed(name, args.seconds)
        parts = ", ".join(
            f"{k} {np.median(v) * 1e3:.2f}/{np.percentile(v, 99) * 1e3:.2f}"
            for k, v in phases.items() if v
        )
        print(f"{name}: real-time factor {m['real_time_factor']:.2f} wall, "
              f"{m['real_time_factor_cpu']:.2f} CPU ({args.seconds:.0f} s sim in "
              f"{m['wall_time']:.1f} s wall); period phases median/p99 [ms]: {parts}; "
              f"load {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
