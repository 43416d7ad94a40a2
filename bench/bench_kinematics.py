"""Benchmark: RobotKinematics.update + 3 contact-centre Jacobians (design §5: ≈ 5 µs).

Run: ``.venv/bin/python bench/bench_kinematics.py [--iterations 20000]`` — prints median and p99
in µs.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from phri_common.procstat import load_line
from phri_description.description import SKIN_LINKS
from wholebody_controller.kinematics import RobotKinematics

LINKS = SKIN_LINKS


def main(iterations: int = 20000) -> None:
    print(load_line())
    kin = RobotKinematics()
    rng = np.random.default_rng(0)
    qs = rng.uniform(-3.0, 3.0, (iterations, 15))
    offsets = [np.array([0.2, 0.0, 0.1]), np.array([0.15, 0.05, 0.04]), np.array([0.2, 0.0, 0.1])]
    outs = [np.empty((6, 15)) for _ in LINKS]
    samples = {"update": np.empty(iterations), "update + 3 point Jacobians": np.empty(iterations),
               "update + 3 point Jacobians (new arrays)": np.empty(iterations)}
    clock = time.perf_counter_ns
    for i in range(iterations):
        q = qs[i]
        t0 = clock()
        kin.update(q)
        t1 = clock()
        samples["update"][i] = t1 - t0
    for i in range(iterations):
        q = qs[i]
        t0 = clock()
        kin.update(q)
        for link, p, out in zip(LINKS, offsets, outs, strict=True):
            kin.point_jacobian(link, p, out=out)
        t1 = clock()
        samples["update + 3 point Jacobians"][i] = t1 - t0
    for i in range(iterations):
        q = qs[i]
        t0 = clock()
        kin.update(q)
        for link, p in zip(LINKS, offsets, strict=True):
            kin.point_jacobian(link, p)
        t1 = clock()
        samples["update + 3 point Jacobians (new arrays)"][i] = t1 - t0
    print(f"RobotKinematics ({iterations} iterations, first 10% discarded)")
    for name, s in samples.items():
        us = s[iterations // 10 :] / 1000.0
        print(f"  {name:42s} median {np.median(us):6.2f} µs   p99 {np.percentile(us, 99):6.2f} µs")


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument("--iterations", type=int, default=20000)
    main(parser.parse_args().iterations)
