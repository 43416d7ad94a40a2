"""Benchmark: simulation speed.

* MuJoCo step time of the full scene with and without the skin model (footprint + noise on the
  three patches every step), median and p99;
* real-time factor of each scenario through the full stack in lock-step (bridge + contact
  estimation + controller in one process).

Run: ``.venv/bin/python bench/bench_sim.py [--seconds 5] [--scenarios centring waltz]``
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from phri_common.testing import isolate_ros_environment
from phri_sim.scenarios import SCENARIOS
from phri_sim.sim import Simulation


def step_times(skins: bool, n: int = 2000) -> np.ndarray:
    sc = SCENARIOS["centring"]
    sim = Simulation()
    sim.reset(np.array(sc.q0))
    script = sc.make_script(sim)
    out = np.empty(n)
    for i in range(n):
        t0 = time.perf_counter()
        for part, target in script(1.5 + sim.time).items():
            sim.set_target(part, target)
        sim.step()
        if skins:
            sim.skin_forces()
        out[i] = time.perf_counter() - t0
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--seconds", type=float, default=5.0, help="sim time per scenario [s]")
    parser.add_argument("--scenarios", nargs="*", default=list(SCENARIOS))
    args = parser.parse_args()
    for skins in (False, True):
        t = step_times(skins) * 1e6
        print(f"step {'with' if skins else 'without'} skins: median {np.median(t):.0f} µs, "
              f"p99 {np.percentile(t, 99):.0f} µs")
    isolate_ros_environment()
    from phri_sim.runner import run_scenario

    for name in args.scenarios:
        m = run_scenario(name, duration=args.seconds)
        print(f"{name}: real-time factor {m['real_time_factor']:.2f} "
              f"({args.seconds:.0f} s sim in {m['wall_time']:.1f} s wall)")


if __name__ == "__main__":
    main()
