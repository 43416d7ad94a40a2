"""Benchmark: the contact estimation node over ROS, 3 patches × N taxels at 500 Hz.

Starts ``contact_estimation_node`` as its own process and a publisher process that sends three
taxel arrays at the skin rate (stamped with the publish time); this process subscribes to the
three contact-state topics (best effort, as the controller reads them). Prints the received
rate per link, drops, latency from publish to reception of the contact state (median / p99) and
the node's CPU use: in all, per contact state delivered and per state for each of its threads
(``/proc/<pid>/task``: the executor thread is named after the node's executable, ``dds.*`` are
Fast DDS's; a thread that used no CPU is left out).

Run: ``.venv/bin/python bench/bench_contact_estimation_ros.py [--seconds 10] [--taxels 2000]``
"""

from __future__ import annotations

import argparse
import multiprocessing
import os
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
import rclpy
from rclpy.executors import SingleThreadedExecutor
from rclpy.qos import QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import PointCloud2

from phri_common.procstat import load_line
from phri_common.ros_main import EXECUTOR_ENV, EXECUTORS
from phri_common.stamps import stamp_to_ns
from phri_common.taxels import TaxelCloudEncoder
from phri_common.testing import isolate_ros_environment
from phri_description.description import SKIN_LINKS, SKIN_PATCHES
from skin_driver.layout import cylinder_taxels
from skin_driver.sim_board import pressed_block

PATCHES = dict(zip(SKIN_PATCHES, SKIN_LINKS, strict=True))
STATE_QOS = QoSProfile(depth=100, reliability=ReliabilityPolicy.BEST_EFFORT)
"""The contact-state subscriptions: best effort, as the controller's (a reliable reader makes
the node's writer answer acknowledgements: ≈ 20 µs of its CPU per state); deeper than the
controller's 25 so this process's own stalls drop nothing."""


def cpu_seconds(pid: int) -> float:
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def thread_cpu_seconds(pid: int) -> dict[str, float]:
    """CPU time [s] of each thread of ``pid`` (``/proc/<pid>/task``), summed by thread name."""
    out: dict[str, float] = {}
    for task in Path(f"/proc/{pid}/task").iterdir():
        try:
            text = (task / "stat").read_text()
        except FileNotFoundError:  # the thread ended
            continue
        name = text.split("(", 1)[1].rsplit(")", 1)[0]
        fields = text.rsplit(")", 1)[1].split()
        out[name] = out.get(name, 0.0) + (int(fields[11]) + int(fields[12])) / os.sysconf(
            "SC_CLK_TCK")
    return out


def publish(seconds: float, taxels: int, rate: float, ready: Any, done: Any) -> None:
    """Publisher process: three patches at ``rate`` for ``seconds`` (frames are never skipped)."""
    rclpy.init()
    node = rclpy.create_node("bench_taxel_publisher")
    rng = np.random.default_rng(0)
    pubs, encoders = {}, {}
    for patch, link in PATCHES.items():
        pubs[patch] = node.create_publisher(PointCloud2, f"skin/{patch}/taxels", 100)
        encoders[patch] = TaxelCloudEncoder(*cylinder_taxels(taxels), link)
    # ADC-like noise (σ 2 mN ≪ σ_t) so no frame repeats the previous one bit for bit: a
    # repeated loaded frame is a stuck skin and the estimator refuses it (stuck_timeout).
    pressed = pressed_block(taxels, 0.1, rng)
    noisy = [pressed + rng.normal(0.0, 0.002, taxels) for _ in range(64)]
    deadline = time.monotonic() + 20.0
    while any(p.get_subscription_count() == 0 for p in pubs.values()):
        rclpy.spin_once(node, timeout_sec=0.05)
        if time.monotonic() > deadline:
            raise SystemExit("contact_estimation_node did not come up within 20 s")
    ready.set()
    time.sleep(1.0)
    frames = int(seconds * rate)
    start = next_t = time.monotonic()
    for k in range(frames):
        for patch in PATCHES:
            pubs[patch].publish(encoders[patch].encode(noisy[k % 64], time.time_ns()))
        next_t += 1.0 / rate
        delay = next_t - time.monotonic()
        if delay > 0:
            time.sleep(delay)
    done.put((frames, time.monotonic() - start))
    node.destroy_node()
    rclpy.try_shutdown()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=10.0)
    parser.add_argument("--taxels", type=int, default=2000)
    parser.add_argument("--rate", type=float, default=500.0)
    args = parser.parse_args()
    print(load_line())
    print(f"node executor (PHRI_EXECUTOR): {os.environ.get(EXECUTOR_ENV) or EXECUTORS[0]}")
    isolate_ros_environment()
    exe = Path(sys.executable).with_name("contact_estimation_node")
    node_proc = subprocess.Popen(
        [str(exe), "--ros-args", "-p", "publish_markers:=false", "--log-level", "warn"]
    )
    rclpy.init()
    node = rclpy.create_node("bench_contact_estimation")
    latencies: dict[str, list[int]] = {link: [] for link in PATCHES.values()}

    def on_state(link: str, msg: PointCloud2) -> None:
        latencies[link].append(time.time_ns() - stamp_to_ns(msg.header.stamp))

    for link in PATCHES.values():
        node.create_subscription(
            PointCloud2, f"contacts/{link}", lambda m, lk=link: on_state(lk, m), STATE_QOS
        )
    ctx = multiprocessing.get_context("spawn")
    ready, done = ctx.Event(), ctx.Queue()
    publisher = ctx.Process(
        target=publish, args=(args.seconds, args.taxels, args.rate, ready, done)
    )
    publisher.start()
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    while not ready.is_set():
        executor.spin_once(timeout_sec=0.05)
        if not publisher.is_alive():
            node_proc.terminate()
            raise SystemExit("the publisher process ended before publishing (see above)")
    for values in latencies.values():
        values.clear()
    cpu0, wall0 = cpu_seconds(node_proc.pid), time.monotonic()
    threads0 = thread_cpu_seconds(node_proc.pid)
    print(f"publishing {args.seconds:g} s × 3 patches × {args.taxels} taxels at {args.rate:g} Hz …")
    result = None
    while result is None:
        executor.spin_once(timeout_sec=0.01)
        if not done.empty():
            result = done.get()
    end = time.monotonic() + 0.5
    while time.monotonic() < end:
        executor.spin_once(timeout_sec=0.01)
    frames, publish_seconds = result
    cpu1, wall1 = cpu_seconds(node_proc.pid), time.monotonic()
    threads1 = thread_cpu_seconds(node_proc.pid)
    publisher.join(timeout=10)
    node_proc.terminate()
    node_proc.wait(timeout=10)
    executor.shutdown()
    node.destroy_node()
    rclpy.try_shutdown()
    print(f"published {frames} frames per patch in {publish_seconds:.1f} s "
          f"({frames / publish_seconds:.0f} Hz)")
    print(f"{'link':<22}{'received':>10}{'rate Hz':>10}{'drops':>8}{'lat med ms':>12}"
          f"{'lat p99 ms':>12}")
    for link, values in latencies.items():
        lat = np.array(values) / 1e6
        print(f"{link:<22}{len(values):>10}{len(values) / publish_seconds:>10.1f}"
              f"{max(0, frames - len(values)):>8}{np.median(lat):>12.2f}"
              f"{np.percentile(lat, 99):>12.2f}")
    states = sum(len(values) for values in latencies.values())
    print(f"node CPU: {100 * (cpu1 - cpu0) / (wall1 - wall0):.0f} % of one core, "
          f"{1e6 * (cpu1 - cpu0) / max(states, 1):.0f} µs per contact state delivered")
    busy = sorted(((threads1[name] - threads0.get(name, 0.0), name) for name in threads1),
                  reverse=True)
    print("  per thread, µs per state: " + ", ".join(
        f"{name} {1e6 * cpu / max(states, 1):.0f}" for cpu, name in busy if cpu > 0))


if __name__ == "__main__":
    main()
