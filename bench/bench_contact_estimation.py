"""Benchmark: contact estimation per call (design §7, issue: 3 links × 2,000 taxels ≤ 60 µs median).

Prints median and p99 for one link of 2,000 / 10,000 / 50,000 taxels, and for the full
per-control-step work on 3 links: new forces for every patch + one batched estimate of all links
(``set_forces`` ×3 + ``estimate``), the per-message path on each PointCloud2 (decode + geometry
comparison + forces + estimate), the node's usual per-message path (the geometry comparison only
every ``geometry_check_interval`` frames; the refusal checks on every frame), and the refusal
checks alone (NaN/Inf positions, normals, forces and the ``max_taxel_force`` bound), so their
share of the per-message cost comes from the same run. The contact covers a realistic ~10 % of
each patch (a forearm against a waist); ``--contact-fraction 1`` gives the worst case.

Run: ``.venv/bin/python bench/bench_contact_estimation.py [--repeats 2000]``
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable

import numpy as np

from contact_estimation.estimator import (
    ContactEstimator,
    EstimatorConfig,
    check_forces,
    check_geometry_values,
)
from phri_common.procstat import load_line
from phri_common.taxels import TaxelCloudEncoder, msg_to_taxels
from phri_description.description import SKIN_LINKS
from skin_driver.layout import cylinder_taxels
from skin_driver.sim_board import pressed_block


def timeit(fn: Callable[[], object], repeats: int) -> tuple[float, float]:
    for _ in range(min(200, repeats)):
        fn()
    samples = np.empty(repeats)
    for i in range(repeats):
        t0 = time.perf_counter_ns()
        fn()
        samples[i] = time.perf_counter_ns() - t0
    return float(np.median(samples)) / 1e3, float(np.percentile(samples, 99)) / 1e3


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=2000)
    parser.add_argument("--contact-fraction", type=float, default=0.1)
    args = parser.parse_args()
    print(load_line())
    rng = np.random.default_rng(0)
    config = EstimatorConfig()
    print(f"contact fraction {args.contact_fraction:.0%}, {args.repeats} repeats; times in µs")
    print(f"{'case':<44}{'median':>10}{'p99':>10}")

    for n in (2_000, 10_000, 50_000):
        pos, nrm = cylinder_taxels(n)
        est = ContactEstimator({"patch": "link"}, config)
        est.set_geometry("patch", pos, nrm)
        forces = pressed_block(n, args.contact_fraction, rng)

        def one_link(e: ContactEstimator = est, f: np.ndarray = forces) -> None:
            e.set_forces("patch", f, 0)
            e.estimate()

        med, p99 = timeit(one_link, args.repeats)
        print(f"{f'1 link × {n:,} taxels':<44}{med:>10.1f}{p99:>10.1f}")

    for n in (2_000, 10_000):
        est = ContactEstimator({f"p{i}": link for i, link in enumerate(SKIN_LINKS)}, config)
        msgs = []
        frames = []
        for i, link in enumerate(SKIN_LINKS):
            pos, nrm = cylinder_taxels(n)
            forces = pressed_block(n, args.contact_fraction, rng)
            msg = TaxelCloudEncoder(pos, nrm, link).encode(forces, 0)
            msgs.append((f"p{i}", msg))
            frames.append((f"p{i}", forces))
            est.set_geometry(f"p{i}", pos, nrm)

        def from_arrays(est: ContactEstimator = est, frames: list = frames) -> None:
            for patch, forces in frames:
                est.set_forces(patch, forces, 0)
            est.estimate()

        def from_messages(est: ContactEstimator = est, msgs: list = msgs) -> None:
            for patch, msg in msgs:
                est.update(patch, msg_to_taxels(msg))

        def node_path(est: ContactEstimator = est, msgs: list = msgs) -> None:
            for patch, msg in msgs:
                est.update(patch, msg_to_taxels(msg), check_geometry=False)

        decoded = [msg_to_taxels(msg) for _, msg in msgs]

        def checks_only(frames: list = decoded, limit: float = config.max_taxel_force) -> None:
            for t in frames:
                check_forces(t.forces, limit)
                check_geometry_values(t.positions, t.normals, t.weights)

        rows: list[tuple[str, Callable[[], object]]] = [
            ("control step", from_arrays),
            ("per message ×3", from_messages),
            ("node path ×3", node_path),
            ("refusal checks ×3", checks_only),
        ]
        for label, fn in rows:
            med, p99 = timeit(fn, args.repeats)
            print(f"{f'3 links × {n:,} taxels ({label})':<44}{med:>10.1f}{p99:>10.1f}")


if __name__ == "__main__":
    main()
