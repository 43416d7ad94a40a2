"""Benchmark: simulated skin boards on ptys → skin_driver_node processes → one subscriber.

Default: 3 boards × 10,000 taxels at 500 Hz, one port (pty) and one driver process per board,
as deployed. Reports per-process CPU %, drops and the latency from the end of a serial frame
(the board's write of its last byte returned) to the subscriber's callback, median and p99.

How latency is matched: taxel 0 of every frame carries the frame index ``k`` as its raw count
(``3000 + k mod 60000``, no noise). The driver runs with its defaults (tare, moving average of
10, drift compensation); taxel 0 is touched at tare (it reads > 0.5 N) so its zero stays the
factory zero, and its published force is ``gain · (mean of the last W counts − offset)``. The
bench computes that mean for every frame the board sent and matches each received message to
the frame whose window it closes (messages after a lost frame stay unmatched and are counted).

The received rate [Hz] is printed per board; ``--taxel-rate HZ`` sets the drivers'
``taxel_publish_rate_hz`` (the composed deployment's throttled taxel topics) to measure that
rate limit on a real machine (the tests check it on a fake clock only).

Run: ``.venv/bin/python bench/bench_skin_driver.py [--duration 10] [--boards 3]
[--taxels 10000] [--rate 500] [--taxel-rate 0]``.
"""

from __future__ import annotations

import argparse
import multiprocessing as mp
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

from phri_common.procstat import load_line

GAIN, OFFSET, BASE = 0.0005, 1000.0, 3000.0
CODE_MOD = 60_000


def _cpu_ticks(pid: int) -> int:
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return int(fields[11]) + int(fields[12])  # utime + stime


def _board_process(
    index: int, link: str, taxels: int, rate: float, stop: Any, queue: Any
) -> None:
    from skin_driver.layout import rectangular_patch
    from skin_driver.sim_board import PtyEndpoint, SimBoard, press_pattern, run_boards

    side = round(taxels**0.5)
    layout = rectangular_patch(f"patch{index}", f"link{index}", side, taxels // side)

    class CodedBoard(SimBoard):
        def counts(self, forces: Any, t: float) -> Any:
            c = super().counts(forces, t)
            c[0] = int(BASE + round(t * rate) % CODE_MOD)
            return c

    board = CodedBoard(0, layout, noise_counts=2.0, seed=index)
    press = press_pattern(layout, force=20.0, radius=0.03, period=1.0)
    sent: list[tuple[int, int]] = []
    last_k = [0]

    def pattern(t: float) -> Any:
        last_k[0] = round(t * rate)
        return press(t)

    def on_sent(board_id: int, seq: int, t_ns: int) -> None:
        sent.append((last_k[0], t_ns))

    stats = run_boards(lambda: PtyEndpoint(link), [(board, pattern)], rate, stop,
                       on_sent=on_sent)
    queue.put((index, np.array(sent, dtype=np.int64), stats.late))


def _percentiles(x: np.ndarray) -> str:
    if x.size == 0:
        return "n/a"
    return f"median {np.median(x):.2f} ms, p99 {np.percentile(x, 99):.2f} ms, max {x.max():.2f} ms"


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--duration", type=float, default=10.0, help="measured seconds")
    p.add_argument("--warmup", type=float, default=2.0, help="seconds ignored after start-up")
    p.add_argument("--boards", type=int, default=3)
    p.add_argument("--taxels", type=int, default=10_000)
    p.add_argument("--rate", type=float, default=500.0, help="[Hz]")
    p.add_argument("--window", type=int, default=10, help="driver filter_window [frames]")
    p.add_argument("--taxel-rate", type=float, default=0.0,
                   help="driver taxel_publish_rate_hz [Hz] (0 = every frame)")
    args = p.parse_args()
    print(load_line())

    os.environ.setdefault("ROS_DOMAIN_ID", str(1 + os.getpid() % 100))
    os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    from skin_driver.layout import rectangular_patch, save_layout

    tmp = Path(tempfile.mkdtemp(prefix="bench_skin_"))
    ctx = mp.get_context("fork")
    stop = ctx.Event()
    queue: Any = ctx.Queue()
    boards, nodes = [], []
    side = round(args.taxels**0.5)
    for i in range(args.boards):
        layout = rectangular_patch(f"patch{i}", f"link{i}", side, args.taxels // side)
        save_layout(layout, tmp / f"patch{i}.yaml")
        proc = ctx.Process(target=_board_process,
                           args=(i, str(tmp / f"port{i}"), args.taxels, args.rate, stop, queue))
        proc.start()
        boards.append(proc)
    for i in range(args.boards):
        while not (tmp / f"port{i}").exists():
            time.sleep(0.01)
        nodes.append(subprocess.Popen([
            sys.executable, "-m", "skin_driver.node", "--ros-args",
            "-r", f"__node:=skin_driver_{i}",
            "-p", f"port:={tmp / f'port{i}'}",
            "-p", "board_ids:=[0]",
            "-p", f"layout_files:=['{tmp / f'patch{i}.yaml'}']",
            "-p", f"filter_window:={args.window}",
            "-p", f"taxel_publish_rate_hz:={args.taxel_rate}",
        ]))

    import rclpy
    from diagnostic_msgs.msg import DiagnosticArray
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.qos import QoSProfile, ReliabilityPolicy
    from sensor_msgs.msg import PointCloud2

    rclpy.init()
    node = rclpy.create_node("bench_listener")
    received: list[list[tuple[int, float, int]]] = [[] for _ in range(args.boards)]
    dropped_by_driver: dict[int, int] = {}

    def make_cb(i: int) -> Any:
        def cb(msg: PointCloud2) -> None:
            now = time.time_ns()
            force0 = float(np.frombuffer(msg.data, dtype="<f4", count=7)[6])
            code = force0 / GAIN + OFFSET - BASE
            stamp = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec
            received[i].append((now, code, stamp))
        return cb

    def on_diag(msg: DiagnosticArray) -> None:
        for s in msg.status:
            for kv in s.values:
                if kv.key == "dropped" and "patch" in s.name:
                    idx = int(s.name.split("patch")[1].split()[0])
                    dropped_by_driver[idx] = int(kv.value)

    qos = QoSProfile(depth=50, reliability=ReliabilityPolicy.RELIABLE)
    for i in range(args.boards):
        node.create_subscription(PointCloud2, f"skin/patch{i}/taxels", make_cb(i), qos)
    node.create_subscription(DiagnosticArray, "/diagnostics", on_diag, 10)
    # Spun on this thread: the EventsExecutor, spun on a helper thread, holds the GIL while it
    # waits and starves the rest of the process (measured: the bench never got past start-up).
    executor = SingleThreadedExecutor()
    executor.add_node(node)

    def spin_for(seconds: float) -> None:
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            executor.spin_once(timeout_sec=min(0.05, max(end - time.monotonic(), 0.0)))

    deadline = time.monotonic() + 30
    while not all(received) and time.monotonic() < deadline:
        spin_for(0.05)
    if not all(received):
        print("no data from every driver within 30 s", file=sys.stderr)
    print(f"receiving: {[len(r) for r in received]}; warming up", file=sys.stderr)
    spin_for(args.warmup)
    pids: dict[str, int] = {f"driver {i}": n.pid for i, n in enumerate(nodes)}
    pids.update({f"board {i}": int(b.pid or 0) for i, b in enumerate(boards)})
    pids["subscriber"] = os.getpid()
    cpu0 = {k: _cpu_ticks(pid) for k, pid in pids.items()}
    counts0 = [len(r) for r in received]
    t0_ns, t0 = time.time_ns(), time.monotonic()
    spin_for(args.duration)
    t1_ns, elapsed = time.time_ns(), time.monotonic() - t0
    cpu1 = {k: _cpu_ticks(pid) for k, pid in pids.items()}
    counts1 = [len(r) for r in received]
    print("measured; collecting", file=sys.stderr)
    spin_for(1.5)  # a diagnostics period, for the drivers' drop counts
    stop.set()
    sent_by_board: dict[int, tuple[np.ndarray, int]] = {}
    for _ in boards:
        i, sent, late = queue.get(timeout=30)
        sent_by_board[i] = (sent, late)
    for n in nodes:
        n.terminate()
    for n in nodes:
        n.wait(10)
    for b in boards:
        b.join(10)
    executor.shutdown()
    node.destroy_node()
    rclpy.try_shutdown()

    shutil.rmtree(tmp, ignore_errors=True)
    tick = os.sysconf("SC_CLK_TCK")
    print(f"skin_driver benchmark: {args.boards} boards × {args.taxels} taxels at "
          f"{args.rate:g} Hz, window {args.window}, {elapsed:.1f} s measured, "
          f"{os.cpu_count()} CPUs")
    for k in pids:
        print(f"  CPU {k:12s} {100.0 * (cpu1[k] - cpu0[k]) / tick / elapsed:6.1f} %")
    all_lat, all_stamp_lat = [], []
    for i in range(args.boards):
        sent, late = sent_by_board[i]
        in_window = (sent[:, 1] >= t0_ns) & (sent[:, 1] < t1_ns)
        n_sent = int(in_window.sum())
        k_window = sent[in_window, 0]
        # Samples the board skipped because it ran late (its process did not get the CPU).
        slips = int(k_window[-1] - k_window[0] + 1 - n_sent) if n_sent else 0
        n_recv = counts1[i] - counts0[i]
        # Expected published value of every sent frame: the mean of the codes of the last W
        # frames the board sent (as sent: schedule slips skip indices, the mean follows).
        codes = (sent[:, 0] % CODE_MOD).astype(np.float64)
        means = np.convolve(codes, np.ones(args.window) / args.window, mode="valid")
        # Consecutive window means differ by ≥ 1 code; the common-mode drift compensation may
        # shift taxel 0 by a few hundredths of a code, so match within ±0.4.
        lookup: dict[int, list[int]] = {}
        for j, m in enumerate(means, start=args.window - 1):
            lookup.setdefault(int(np.floor(m)), []).append(j)
        lat, stamp_lat, unmatched = [], [], 0
        for now, code, stamp in received[i][counts0[i]:counts1[i]]:
            # The newest sent frame whose window mean matches and that was sent before `now`.
            base = int(np.floor(code))
            hits = sorted(
                j
                for key in (base - 1, base, base + 1)
                for j in lookup.get(key, [])
                if abs(means[j - args.window + 1] - code) < 0.4 and sent[j, 1] <= now
            )
            if not hits:
                unmatched += 1
                continue
            lat.append((now - sent[hits[-1], 1]) / 1e6)
            stamp_lat.append((now - stamp) / 1e6)
        lat_a, stamp_a = np.array(lat), np.array(stamp_lat)
        all_lat.append(lat_a)
        all_stamp_lat.append(stamp_a)
        print(f"  board {i}: sent {n_sent}, received {n_recv} "
              f"({100.0 * n_recv / max(n_sent, 1):.1f} %, {n_recv / elapsed:.0f} Hz), "
              f"sequence gaps seen by the driver "
              f"{dropped_by_driver.get(i, 'n/a')}, board schedule slips {slips} "
              f"(whole run {late}), "
              f"unmatched {unmatched}")
        print(f"    frame end → subscriber: {_percentiles(lat_a)}")
    lat_all = np.concatenate(all_lat) if all_lat else np.array([])
    stamp_all = np.concatenate(all_stamp_lat) if all_stamp_lat else np.array([])
    print(f"  all boards, frame end → subscriber: {_percentiles(lat_all)}")
    print(f"  all boards, header.stamp (board sampling time, host clock) → subscriber: "
          f"{_percentiles(stamp_all)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
