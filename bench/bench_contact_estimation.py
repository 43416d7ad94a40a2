"""Benchmark: contact estimation per call (target: 3 links × 2,000 taxels ≲ 15 µs, × 10,000 ≲ 45).

Prints median and p99 for one link of 2,000 / 10,000 / 50,000 taxels, and for the full
per-control-step work on 3 links: new forces for every patch + one batched estimate of all links
(``set_forces`` ×3 + ``estimate``), that step's two halves (``set_forces`` ×3: the checks, and
with the numba kernel the per-patch sums; ``estimate``: the states), the same step with no taxel
over σ_t (an idle skin), the per-message path on each PointCloud2 (decode + geometry
comparison + forces + estimate), the node's usual per-message path (the geometry comparison only
every ``geometry_check_interval`` frames; the refusal checks on every frame), the node's path
from a message's serialized bytes (``taxel_table_from_cdr`` + ``update_table`` + ``contact_to_cdr``:
what it runs per message since it reads the bytes in place), and the refusal
checks alone (NaN/Inf positions, normals, forces and the ``max_taxel_force`` bound), so their
share of the per-message cost comes from the same run. The contact covers a realistic ~10 % of
each patch (a forearm against a waist) and slides by 3 taxels per frame, so no frame repeats the
last one (a repeated frame is cheaper: nothing changed); ``--contact-fraction 1`` gives the worst
case, ``--kernel numpy`` the reference.

Run: ``.venv/bin/python bench/bench_contact_estimation.py [--repeats 2000]``
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable
from typing import Generic, TypeVar

import numpy as np
from rclpy.serialization import serialize_message

from contact_estimation.estimator import (
    KERNELS,
    ContactEstimator,
    EstimatorConfig,
    check_forces,
    check_geometry_values,
)
from phri_common.contact_cdr import contact_to_cdr
from phri_common.procstat import load_line
from phri_common.taxels import TaxelCloudEncoder, msg_to_taxels
from phri_common.taxels_cdr import taxel_table_from_cdr
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
    parser.add_argument("--kernel", choices=KERNELS, default=KERNELS[0])
    args = parser.parse_args()
    print(load_line())
    rng = np.random.default_rng(0)
    config = EstimatorConfig(kernel=args.kernel)
    print(f"contact fraction {args.contact_fraction:.0%}, {args.kernel} kernel, {args.repeats} "
          "repeats; times in µs")
    print(f"{'case':<54}{'median':>10}{'p99':>10}")

    for n in (2_000, 10_000, 50_000):
        pos, nrm = cylinder_taxels(n)
        est = ContactEstimator({"patch": "link"}, config)
        est.set_geometry("patch", pos, nrm)
        cycle = Frames(sliding(n, args.contact_fraction, rng))

        def one_link(e: ContactEstimator = est, c: Frames = cycle) -> None:
            forces, stamp = c.next()
            e.set_forces("patch", forces, stamp)
            e.estimate()

        med, p99 = timeit(one_link, args.repeats)
        print(f"{f'1 link × {n:,} taxels':<54}{med:>10.1f}{p99:>10.1f}")

    for n in (2_000, 10_000):
        three_links(n, config, args, rng)

T = TypeVar("T")


class Frames(Generic[T]):
    """A cycle of frames (force arrays [N], messages or their bytes) with increasing stamps [ns]
    (2 ms apart, as at 500 Hz)."""

    def __init__(self, frames: list[T]) -> None:
        self.frames, self.k = frames, 0

    def next(self) -> tuple[T, int]:
        self.k += 1
        return self.frames[self.k % len(self.frames)], 2_000_000 * self.k


def sliding(n: int, fraction: float, rng: np.random.Generator, count: int = 16) -> list:
    """``count`` frames of a pressed block of ``fraction`` of n taxels, 3 taxels further each."""
    base = pressed_block(n, fraction, rng)
    return [np.roll(base, 3 * k) for k in range(count)]


def three_links(n: int, config: EstimatorConfig, args: argparse.Namespace,
                rng: np.random.Generator) -> None:
    """The rows of 3 links × n taxels (module docstring)."""
    est = ContactEstimator({f"p{i}": link for i, link in enumerate(SKIN_LINKS)}, config)
    idle = ContactEstimator({f"p{i}": link for i, link in enumerate(SKIN_LINKS)}, config)
    msgs, frames, idle_frames = [], [], []
    for i, link in enumerate(SKIN_LINKS):
        pos, nrm = cylinder_taxels(n)
        cycle = sliding(n, args.contact_fraction, rng)
        encoder = TaxelCloudEncoder(pos, nrm, link)
        msgs.append((f"p{i}", Frames([encoder.encode(f, 0) for f in cycle[:8]])))
        frames.append((f"p{i}", Frames(cycle)))
        # Noise only, below σ_t: the idle skin of a robot nobody touches.
        idle_frames.append((f"p{i}", Frames([f * (f < config.force_threshold) for f in cycle])))
        est.set_geometry(f"p{i}", pos, nrm)
        idle.set_geometry(f"p{i}", pos, nrm)

    def take(est: ContactEstimator = est, frames: list = frames) -> None:
        for patch, cycle in frames:
            est.set_forces(patch, *cycle.next())

    def from_arrays(est: ContactEstimator = est) -> None:
        take()
        est.estimate()

    def idle_step(est: ContactEstimator = idle, frames: list = idle_frames) -> None:
        take(est, frames)
        est.estimate()

    def from_messages(est: ContactEstimator = est, msgs: list = msgs) -> None:
        for patch, cycle in msgs:
            est.update(patch, msg_to_taxels(cycle.next()[0]))

    def node_path(est: ContactEstimator = est, msgs: list = msgs) -> None:
        for patch, cycle in msgs:
            est.update(patch, msg_to_taxels(cycle.next()[0]), check_geometry=False)

    wire = [(patch, Frames([serialize_message(m) for m in cycle.frames])) for patch, cycle in msgs]

    def from_bytes(est: ContactEstimator = est, wire: list = wire) -> None:
        for k, (patch, cycle) in enumerate(wire):
            frame = taxel_table_from_cdr(cycle.next()[0])
            assert frame is not None
            contact_to_cdr(est.update_table(patch, frame[2], 2_000_000 * cycle.k + k,
                                            check_geometry=False))

    decoded = [msg_to_taxels(cycle.frames[0]) for _, cycle in msgs]

    def checks_only(frames: list = decoded, limit: float = config.max_taxel_force) -> None:
        for t in frames:
            check_forces(t.forces, limit)
            check_geometry_values(t.positions, t.normals, t.weights)

    rows: list[tuple[str, Callable[[], object]]] = [
        ("control step", from_arrays),
        ("· set_forces ×3", take),
        ("· estimate", est.estimate),
        ("control step, idle skin", idle_step),
        ("per message ×3", from_messages),
        ("node path ×3", node_path),
        ("node, serialized ×3", from_bytes),
        ("refusal checks ×3", checks_only),
    ]
    for label, fn in rows:
        med, p99 = timeit(fn, args.repeats)
        print(f"{f'3 links × {n:,} taxels ({label})':<54}{med:>10.1f}{p99:>10.1f}")


if __name__ == "__main__":
    main()
