"""Benchmark: the whole 500 Hz chain, end to end, each node in its own process as deployed.

Simulated boards (one process and one pty per board; ``--transport socket``: a TCP server per
board on localhost, as boards on Ethernet, since a pty holds about 20 KB, one 10,000-taxel
frame, read back 4,095 bytes a read, so a board on a pty waits for the reader within almost
every frame; the boards draw their noise
from a bank of 64 frames so that, standing in for hardware, they load the host less) →
``skin_driver`` nodes (one per port) →
``contact_estimation`` → ``wholebody_controller`` at ``--controller-rate``. This process stands
in for the arm bridges and the base: it publishes ``/joint_states`` and ``/odom`` at
``--inputs-rate``. Every link is pressed all the time (all three links in contact).

Reported over the measured window (after start-up and ``--warmup``):

* frames sent by each board and contact states of its link that reached the controller; a
  frame that never arrived as a contact state is **dropped** (by the driver, the estimator or
  DDS). A frame whose tail the board could not write because the pty stayed full for its write
  timeout (the driver did not read for ≈ 18 ms: 16 KB of pty buffer, 10 ms timeout) is counted
  as **cut off at the pty**; the **stages** line gives, per link, the rates at which frames were
  sent, cut off, parsed intact by the driver and taken by the estimator (both from their
  ``/diagnostics`` counters) and arrived in the controller, so a drop can be placed;
* latency from a frame's last byte (the board's ``write()`` of it returned, wall clock) to
  (a) the contact state's arrival in the controller process and (b) the end of the first control
  cycle whose command used it: **frame end → command**. A frame superseded by the next one
  before any cycle ran is counted as "not used" (the controller samples at its own rate);
* CPU of every process (utime + stime from ``/proc``) as % of one core, the machine's busy cores
  over the window from ``/proc/stat`` and its load average.

How a command is attributed to its frame: the frame's index is coded into its press force. Board
frame k presses its patch with ``F_k = F0 + δ·(k mod M)`` [N] (every taxel of the press > 0.5 N,
so the driver's tare keeps their factory zero); the driver's moving average (window W) then
publishes the mean of the last W pressed forces, and the estimator's resultant (9a) is that mean
up to the ADC noise (≈ mN ≪ δ). The bench computes this expected value for every frame the board
sent and matches each contact state to the frame, among those whose board time lies within
±M/4 frames of the state's stamp (the stamp is the board time mapped to the host clock; it
travels unchanged from driver to estimator to controller), whose expected force is closest,
within δ/2. The expected force skips frames cut off at the pty (they never reach the moving
average) and restarts after a board silence longer than the driver's ``silence_timeout``.
The controller process runs the real node class and entry point (``run_nodes``) with two
probes: on every contact message it records (link, stamp, arrival time, |force|);
after every control cycle that published a command, (end time, stamp of each link's contact
state used). Commands map to frames through those stamps. Nothing in the node's code changes.

``--composed HZ`` runs the drivers and the estimator in one process instead
(``phri_bringup.skin_contact_node``: direct hand-off, taxel topics at HZ), its estimator
probed as well: every frame it took and every contact state it published, by stamp. The
**by stamp** line then counts exactly, per link: frames sent, taken, published, published but
never received by the controller (and the bursts they were lost in), received but never
published. The **pauses** line gives each probed process's full (generation-2) garbage
collections and rclpy log calls inside the window, and the controller's longest cycle: the
whole-process pauses that lost frames before ``phri_common.settle`` (docs/benchmarks.md).
``--save DIR`` keeps the raw records (.npz) for a closer look.

Run: ``.venv/bin/python bench/bench_chain.py [--seconds 60] [--taxels 2000] [--boards 3]
[--rate 500] [--executor events|single] [--composed 50] [--no-markers] [--priority 50]
[--save DIR]``. ``--priority N`` runs the skin drivers' reading thread and the controller's
control thread under SCHED_FIFO at N (their ``thread_priority``, as a robot PC would) and the
simulated boards too (they stand in for hardware).
Keep runs ≤ 2 min on a shared machine.
"""

from __future__ import annotations

import argparse
import multiprocessing as mp
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from phri_common.procstat import MachineCpu, load_line, process_cpu_s
from phri_common.ros_main import EXECUTORS
from phri_common.testing import isolate_ros_environment
from phri_description.description import SKIN_LINKS, SKIN_PATCHES

F0, DELTA, MODULUS = 10.0, 0.05, 200
"""Press force code: frame k presses with F0 + DELTA·(k mod MODULUS) [N] (10–20 N)."""
PRESS_RADIUS = 0.012
"""Press radius [m]: a few taxels, each well above the driver's tare_max_shift (0.5 N)."""
FILTER_WINDOW = 10
"""The driver's moving-average window (its default, the paper's)."""
SILENCE_NS = 0.1e9
"""The driver's silence_timeout [ns] (its default): a board quiet this long restarts its
moving average."""


# -- simulated boards ---------------------------------------------------------------------------
def _board_process(index: int, port: str, layout_file: str, rate: float, stop: Any,
                   queue: Any, priority: int = 0, transport: str = "pty") -> None:
    """One board on its own pty (or TCP server: ``transport`` socket, its URL written to
    ``port``.url), pressed with the coded force; report per frame sent:
    (board time [ns], write end [ns, wall clock], press force [µN], cut off: 1 when the pty
    was full for the write timeout and the frame's tail was dropped, as a UART would). With
    ``priority`` > 0 under SCHED_FIFO: a board is hardware, which other load never delays."""
    from phri_common.periodic import set_fifo_priority
    from skin_driver.layout import load_layout

    if priority > 0:
        set_fifo_priority(priority)
    from skin_driver.sim_board import (
        PtyEndpoint,
        SimBoard,
        TcpEndpoint,
        press_pattern,
        run_boards,
    )

    layout = load_layout(layout_file)
    board = SimBoard(0, layout, noise_counts=2.0, seed=index, noise_bank=64)
    unit = press_pattern(layout, force=1.0, radius=PRESS_RADIUS, period=0.0)(0.0)
    sent: list[tuple[int, int, int, int]] = []
    last = [0.0, 0.0]
    endpoints: list[PtyEndpoint | TcpEndpoint] = []
    overflows = [0]

    def pattern(t: float) -> Any:
        force = F0 + DELTA * (round(t * rate) % MODULUS)
        last[:] = [t, force]
        return unit * force

    def on_sent(_board: int, _seq: int, t_ns: int) -> None:
        total = sum(e.overflows for e in endpoints)
        sent.append((int(last[0] * 1e6) * 1000, t_ns, round(last[1] * 1e6),
                     int(total > overflows[0])))
        overflows[0] = total

    def open_endpoint() -> PtyEndpoint | TcpEndpoint:
        if transport == "socket":
            endpoints.append(TcpEndpoint())
            url = Path(port + ".url")
            url.with_suffix(".tmp").write_text(endpoints[-1].path)
            url.with_suffix(".tmp").replace(url)
        else:
            endpoints.append(PtyEndpoint(port))
        return endpoints[-1]

    stats = run_boards(open_endpoint, [(board, pattern)], rate, stop, on_sent=on_sent)
    queue.put((index, np.array(sent, dtype=np.int64).reshape(-1, 4), stats.late))


# -- the controller process ---------------------------------------------------------------------
PROBED_METHODS = ("take_contact", "tick", "destroy_node")
"""The controller node's methods the probe wraps (a renamed one would silently record nothing:
``test_bench_scripts.py`` checks they exist)."""


PROBED_ESTIMATION_METHODS = ("on_frame", "destroy_node")
"""The estimation node's methods the composed probe wraps (``test_bench_scripts.py``)."""


def run_controller_probe(out: str, ros_args: Sequence[str]) -> int:
    """The controller node as deployed (``run_nodes``), with recording probes (module doc)."""
    from phri_common.ros_main import run_nodes
    from wholebody_controller.node import WholeBodyControllerNode

    links = list(SKIN_LINKS)
    arrivals: list[tuple[int, int, int, int]] = []
    commands: list[tuple[int, ...]] = []

    received: list[tuple[int, int, int, int]] = []
    ticks: list[tuple[int, int]] = []
    collections = _record_gc()
    logs = _record_logs()
    slices = _record_slices()

    class ProbedController(WholeBodyControllerNode):
        def take_contact(self, link: str, state: Any) -> None:
            now = time.time_ns()
            super().take_contact(link, state)
            kept = self.contacts.get(link) is state
            received.append((links.index(link), state.stamp_ns, now, int(kept)))
            if kept:
                force = round(float(np.linalg.norm(state.force)) * 1e6)  # [µN]
                arrivals.append((links.index(link), state.stamp_ns, now, force))

        def tick(self) -> None:
            good = self.good_cycles
            start = time.time_ns()
            super().tick()
            ticks.append((start, time.time_ns()))
            if self.good_cycles > good:
                used = [self.contacts[k].stamp_ns if k in self.contacts else 0 for k in links]
                commands.append((time.time_ns(), *used))
                if len(commands) == 1:
                    Path(out + ".ready").touch()

        def destroy_node(self) -> None:
            super().destroy_node()
            np.savez(out, arrivals=np.array(arrivals, dtype=np.int64).reshape(-1, 4),
                     commands=np.array(commands, dtype=np.int64).reshape(-1, 1 + len(links)),
                     received=np.array(received, dtype=np.int64).reshape(-1, 4),
                     slices=np.array(slices, dtype=np.int64).reshape(-1, 2),
                     ticks=np.array(ticks, dtype=np.int64).reshape(-1, 2),
                     gc=np.array(collections, dtype=np.int64).reshape(-1, 3),
                     logs=np.array(logs, dtype=np.int64).reshape(-1, 2),
                     rejected=np.array(getattr(self, "rejected_inputs", -1)))

    return run_nodes(lambda: [ProbedController()], "bench_chain_controller",
                     ["bench_chain", "--ros-args", *ros_args])


def _record_slices() -> list[tuple[int, int]]:
    """Record (start, end) [ns, wall clock] of every executor slice of this process
    (``phri_common.ros_main.SliceSpinner.spin_slice``)."""
    from phri_common import ros_main

    slices: list[tuple[int, int]] = []
    spin_slice = ros_main.SliceSpinner.spin_slice

    def recorded(self: Any) -> None:
        start = time.time_ns()
        spin_slice(self)
        slices.append((start, time.time_ns()))

    ros_main.SliceSpinner.spin_slice = recorded
    return slices


def _record_gc() -> list[tuple[int, int, int]]:
    """Record (start, end [ns, wall clock], generation) of every garbage collection."""
    import gc

    collections: list[tuple[int, int, int]] = []
    started = [0]

    def callback(phase: str, info: dict[str, int]) -> None:
        if phase == "start":
            started[0] = time.time_ns()
        else:
            collections.append((started[0], time.time_ns(), info["generation"]))

    gc.callbacks.append(callback)
    return collections


def _record_logs() -> list[tuple[int, int]]:
    """Record (start, end) [ns, wall clock] of every rclpy logger call of this process."""
    from rclpy.impl import rcutils_logger
    from rclpy.impl.rcutils_logger import RcutilsLogger

    # rclpy keys its throttling by the first caller outside its own files: skip this one too.
    rcutils_logger._internal_callers.append(os.path.realpath(__file__))
    calls: list[tuple[int, int]] = []
    log = RcutilsLogger.log

    def recorded(self: Any, *args: Any, **kwargs: Any) -> bool:
        start = time.time_ns()
        try:
            return bool(log(self, *args, **kwargs))
        finally:
            calls.append((start, time.time_ns()))

    RcutilsLogger.log = recorded  # type: ignore[method-assign]
    return calls


class _RecordingPublisher:
    """Stands in for a contact-state publisher: records (link, stamp, time) and publishes."""

    def __init__(self, publisher: Any, link: int, records: list[tuple[int, int, int]]) -> None:
        self._publisher, self._link, self._records = publisher, link, records

    def publish(self, data: bytes) -> None:
        from phri_common.contact_cdr import cloud_header

        header = cloud_header(data)
        self._publisher.publish(data)
        self._records.append((self._link, header[1] if header else -1, time.time_ns()))


def run_composed_probe(out: str, argv: Sequence[str]) -> int:
    """The composed drivers + estimation process as deployed, its estimator probed: every
    frame it took (patch, stamp, time) and every contact state it published (link, stamp,
    time), so that published and arrived states compare by stamp, exactly."""
    import phri_bringup.skin_contact_node as skin_contact_node
    from contact_estimation.node import ContactEstimationNode

    taken: list[tuple[int, int, int]] = []
    published: list[tuple[int, int, int]] = []
    slices = _record_slices()
    collections = _record_gc()
    logs = _record_logs()

    class ProbedEstimation(ContactEstimationNode):  # methods: PROBED_ESTIMATION_METHODS
        def __init__(self, **kwargs: Any) -> None:
            super().__init__(**kwargs)
            pubs = self._state_pubs
            for link in list(pubs):
                pubs[link] = _RecordingPublisher(pubs[link], SKIN_LINKS.index(link), published)

        def on_frame(self, patch: str, taxels: Any) -> None:
            taken.append((SKIN_PATCHES.index(patch), taxels.stamp_ns, time.time_ns()))
            super().on_frame(patch, taxels)

        def destroy_node(self) -> None:
            super().destroy_node()
            np.savez(out, taken=np.array(taken, dtype=np.int64).reshape(-1, 3),
                     published=np.array(published, dtype=np.int64).reshape(-1, 3),
                     slices=np.array(slices, dtype=np.int64).reshape(-1, 2),
                     gc=np.array(collections, dtype=np.int64).reshape(-1, 3),
                     logs=np.array(logs, dtype=np.int64).reshape(-1, 2))

    skin_contact_node.ContactEstimationNode = ProbedEstimation
    return skin_contact_node.main(["skin_contact_node", *argv])


# -- start-up -----------------------------------------------------------------------------------
def _write_layouts(tmp: Path, boards: int, taxels: int) -> list[Path]:
    from skin_driver.layout import rectangular_patch, save_layout

    side = round(taxels**0.5)
    files = []
    for i in range(boards):
        layout = rectangular_patch(SKIN_PATCHES[i], SKIN_LINKS[i], side, taxels // side)
        files.append(tmp / f"{SKIN_PATCHES[i]}.yaml")
        save_layout(layout, files[-1])
    return files


def _composed_params(tmp: Path, layouts: list[Path], args: argparse.Namespace) -> Path:
    """Parameter file of the composed process: one section per driver node, one estimator."""
    import yaml

    sections: dict[str, Any] = {
        f"skin_driver_{i}": {"ros__parameters": {
            "port": _board_port(tmp, i, args.transport), "board_ids": [0],
            "layout_files": [str(layout)],
            "taxel_publish_rate_hz": float(args.composed),
            "thread_priority": args.priority}}
        for i, layout in enumerate(layouts)
    }
    sections["contact_estimation"] = {"ros__parameters": {
        "publish_markers": args.markers, "marker_rate_hz": args.marker_rate}}
    path = tmp / "composed.yaml"
    path.write_text(yaml.safe_dump(sections))
    return path


def _board_port(tmp: Path, i: int, transport: str) -> str:
    """What driver ``i`` opens: the board's pty link, or its ``socket://`` URL; waits up to
    30 s for the board to create it."""
    path = tmp / (f"port{i}.url" if transport == "socket" else f"port{i}")
    deadline = time.monotonic() + 30.0
    while not path.exists() and time.monotonic() < deadline:
        time.sleep(0.01)
    return path.read_text() if transport == "socket" else str(path)


def _start_nodes(tmp: Path, layouts: list[Path], args: argparse.Namespace,
                 ) -> dict[str, subprocess.Popen[bytes]]:
    bindir = Path(sys.executable).parent
    env = dict(os.environ, PHRI_EXECUTOR=args.executor)
    procs: dict[str, subprocess.Popen[bytes]] = {}
    if args.composed is not None:
        procs["skin_contact_node (drivers+estimation)"] = subprocess.Popen(
            [sys.executable, __file__, "--composed-probe", str(tmp / "composed"), "--drivers",
             *(f"skin_driver_{i}" for i in range(len(layouts))), "--ros-args",
             "--params-file", str(_composed_params(tmp, layouts, args))], env=env)
    else:
        for i, layout in enumerate(layouts):
            procs[f"skin_driver {i}"] = subprocess.Popen([
                str(bindir / "skin_driver_node"), "--ros-args", "-r",
                f"__node:=skin_driver_{i}", "-p",
                f"port:={_board_port(tmp, i, args.transport)}",
                "-p", "board_ids:=[0]", "-p", f"layout_files:=['{layout}']",
                "-p", f"thread_priority:={args.priority}",
            ], env=env)
        procs["contact_estimation"] = subprocess.Popen(
            [str(bindir / "contact_estimation_node"), "--ros-args",
             "-p", f"publish_markers:={'true' if args.markers else 'false'}",
             "-p", f"marker_rate_hz:={args.marker_rate}"], env=env)
    procs["wholebody_controller"] = subprocess.Popen(
        [sys.executable, __file__, "--controller-probe", str(tmp / "controller"),
         "--ros-args", "-p", f"rate_hz:={args.controller_rate}",
         "-p", f"thread_priority:={args.priority}"], env=env)
    return procs


class Inputs:
    """Publishes the controller's other inputs (joint states, odometry) from this process, and
    records every ``/diagnostics`` status of the drivers and the estimator (stage counts)."""

    def __init__(self, rate: float) -> None:
        import rclpy
        from diagnostic_msgs.msg import DiagnosticArray
        from nav_msgs.msg import Odometry
        from rclpy.executors import SingleThreadedExecutor
        from sensor_msgs.msg import JointState

        from wholebody_controller.kinematics import JOINT_NAMES

        rclpy.init()
        self.node = rclpy.create_node("bench_chain_inputs")
        self._joints = self.node.create_publisher(JointState, "/joint_states", 10)
        self._odom = self.node.create_publisher(Odometry, "/odom", 10)
        self.diagnostics: list[tuple[int, str, dict[str, str]]] = []
        """(stamp [ns], status name, values) of every skin_driver / contact_estimation status."""
        self.node.create_subscription(DiagnosticArray, "/diagnostics", self._on_diagnostics, 50)
        self._executor = SingleThreadedExecutor()
        self._executor.add_node(self.node)
        q_arms = [0.3, -1.2, 1.5, -1.0, -1.57, 0.0, -0.3, -1.9, -1.5, -1.0, 1.57, 0.0]
        self._joint_msg = JointState(name=list(JOINT_NAMES[3:]), position=q_arms)
        self._odom_msg = Odometry()
        self._odom_msg.pose.pose.orientation.w = 1.0
        self.period = 1.0 / rate
        self._next = self._next_drain = time.monotonic()

    def _on_diagnostics(self, msg: Any) -> None:
        stamp = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec
        for status in msg.status:
            if status.name.startswith(("skin_driver: ", "contact_estimation: ")):
                self.diagnostics.append(
                    (stamp, status.name, {kv.key: kv.value for kv in status.values}))

    def run_until(self, done: Any, timeout: float) -> bool:
        """Publish at the rate until ``done()`` or ``timeout`` [s]; return ``done()``."""
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            if done():
                return True
            self._joints.publish(self._joint_msg)
            self._odom.publish(self._odom_msg)
            self._next = max(self._next + self.period, time.monotonic() - self.period)
            if time.monotonic() >= self._next_drain:  # diagnostics: stamped, ~5 a second
                self._next_drain = time.monotonic() + 0.25
                for _ in range(20):
                    self._executor.spin_once(timeout_sec=0.0)
            time.sleep(max(0.0, self._next - time.monotonic()))
        return bool(done())

    def close(self) -> None:
        import rclpy

        self._executor.shutdown()
        self.node.destroy_node()
        rclpy.try_shutdown()


def stage_rate(diagnostics: list[tuple[int, str, dict[str, str]]], name: str, key: str,
               window: tuple[int, int]) -> float:
    """Rate [1/s] at which the cumulative counter ``key`` of status ``name`` grew between its
    first and last report inside ``window`` (stamps [ns]); NaN without two reports."""
    points = [(t, float(v[key])) for t, n, v in diagnostics
              if n == name and key in v and window[0] <= t <= window[1]]
    if len(points) < 2 or points[-1][0] <= points[0][0]:
        return float("nan")
    return (points[-1][1] - points[0][1]) / ((points[-1][0] - points[0][0]) / 1e9)


# -- analysis -----------------------------------------------------------------------------------
def expected_forces(pressed_un: np.ndarray, window: int = FILTER_WINDOW,
                    cut: np.ndarray | None = None, board_ns: np.ndarray | None = None,
                    silence_ns: float = SILENCE_NS) -> np.ndarray:
    """The resultant [µN] the driver's moving average makes of each sent frame's press force:
    the mean of the last ``window`` frames that reached it (fewer at the start). A frame ``cut``
    off at the full pty never reached it (its own entry is then meaningless); a gap in board
    time longer than the driver's silence timeout empties its window (``reset_filter``)."""
    n = len(pressed_un)
    ok = np.ones(n, dtype=bool) if cut is None else ~cut.astype(bool)
    values = np.where(ok, pressed_un.astype(np.float64), 0.0)
    segment = np.zeros(n, dtype=np.int64)
    if board_ns is not None and n > 1:
        segment[1:] = np.cumsum(np.diff(board_ns) > silence_ns)
    sums = np.cumsum(np.concatenate([[0.0], values]))
    counts = np.cumsum(np.concatenate([[0], ok.astype(np.int64)]))
    # Index (into sums/counts) where each frame's window starts: `window` good frames back,
    # but not before its segment's first frame.
    good_index = np.flatnonzero(ok)
    rank = counts[1:]  # good frames up to and including each frame
    back = np.maximum(rank - window, 0)
    start = np.where(back > 0, good_index[np.maximum(back - 1, 0)] + 1, 0) if good_index.size \
        else np.zeros(n, dtype=np.int64)
    first = np.searchsorted(segment, segment, side="left")
    start = np.maximum(start, first)
    ends = np.arange(1, n + 1)
    taken = np.maximum(counts[ends] - counts[start], 1)
    return np.asarray((sums[ends] - sums[start]) / taken)


def match_frames(stamps: np.ndarray, forces_un: np.ndarray, sent: np.ndarray,
                 period_ns: float) -> np.ndarray:
    """Index of the sent frame each contact state came from (−1: none matches; module doc).

    ``sent`` rows: board time [ns], write end [ns], press force [µN]. Candidates are the
    frames within ±MODULUS/4 frames of the stamp's board time whose expected filtered force
    lies within DELTA/2 of the state's; the match is the one nearest in board time (after the
    code wraps, MODULUS frames, the moving average passes through values it also takes a few
    tens of frames away: the closest force alone then picked the wrong frame ≈ 2 % of the time).
    """
    board_ns = sent[:, 0]
    offset = int(np.min(sent[:, 1] - board_ns))  # host clock − board clock, to a few ms
    expected = expected_forces(sent[:, 2], cut=sent[:, 3], board_ns=board_ns)
    centre = np.searchsorted(board_ns, stamps - offset)
    span = MODULUS // 4
    candidates = np.clip(centre[:, None] + np.arange(-span, span + 1), 0, len(sent) - 1)
    distance = np.abs(board_ns[candidates] - (stamps - offset)[:, None]).astype(np.float64)
    fits = (distance <= span * period_ns) & \
        (np.abs(expected[candidates] - forces_un[:, None]) < DELTA * 1e6 / 2)
    score = np.where(fits, distance, np.inf)
    best = np.argmin(score, axis=1)
    rows = np.arange(len(stamps))
    return np.where(np.isfinite(score[rows, best]), candidates[rows, best], -1)


def _ms(x: np.ndarray) -> str:
    if x.size == 0:
        return "n/a"
    return (f"median {np.median(x) / 1e6:.2f} ms, p99 {np.percentile(x, 99) / 1e6:.2f} ms, "
            f"max {x.max() / 1e6:.2f} ms")


def analyse_link(i: int, sent: np.ndarray, records: Any, window: tuple[int, int],
                 period_ns: float) -> tuple[dict[str, int], np.ndarray, np.ndarray]:
    """Counts, frame end → contact arrival and frame end → command latencies [ns] of link i."""
    write_end = sent[:, 1]
    in_window = (write_end >= window[0]) & (write_end < window[1])
    arrivals = records["arrivals"]
    arrivals = arrivals[arrivals[:, 0] == i]
    idx = match_frames(arrivals[:, 1], arrivals[:, 3], sent, period_ns)
    arrived = np.zeros(len(sent), dtype=bool)
    arrived[idx[idx >= 0]] = True
    # First arrival of each frame, and the frame of each stamp.
    first = {int(j): int(t) for j, t in zip(idx[::-1], arrivals[::-1, 2], strict=True)}
    frame_of = {int(s): int(j) for s, j in zip(arrivals[:, 1], idx, strict=True) if j >= 0}
    to_state = np.array([first[j] - write_end[j]
                         for j in np.flatnonzero(in_window).tolist() if j in first],
                        dtype=np.int64)
    commands = records["commands"]
    used = np.array([frame_of.get(int(s), -1) for s in commands[:, 1 + i]], dtype=np.int64)
    firsts, where = np.unique(used, return_index=True)
    keep = (firsts >= 0) & in_window[np.maximum(firsts, 0)]
    to_command = commands[where[keep], 0] - write_end[firsts[keep]]
    in_arrivals = (arrivals[:, 2] >= window[0]) & (arrivals[:, 2] < window[1])
    counts = {
        "sent": int(in_window.sum()),
        "arrived": int((arrived & in_window).sum()),
        "cut": int((in_window & ~arrived & (sent[:, 3] > 0)).sum()),
        "used": int(keep.sum()),
        "unmatched": int(((idx < 0) & in_arrivals).sum()),
    }
    return counts, to_state, to_command


def print_stages(i: int, sent: np.ndarray, records: Any, window: tuple[int, int],
                 diagnostics: list[tuple[int, str, dict[str, str]]]) -> None:
    """Where link i's frames were lost, as rates [1/s] over the window: sent by the board, cut
    off at the full pty, parsed intact by the driver (its /diagnostics ``frames``), taken by the
    estimator (``frames_received``), contact states arriving in the controller."""
    seconds = (window[1] - window[0]) / 1e9
    write_end = sent[:, 1]
    inside = (write_end >= window[0]) & (write_end < window[1])
    arrivals = records["arrivals"]
    arrived = arrivals[(arrivals[:, 0] == i) & (arrivals[:, 2] >= window[0])
                       & (arrivals[:, 2] < window[1])]
    patch = SKIN_PATCHES[i]
    rates = {
        "sent": inside.sum() / seconds,
        "cut at the pty": (inside & (sent[:, 3] > 0)).sum() / seconds,
        "driver parsed": stage_rate(diagnostics, f"skin_driver: {patch} (board 0)", "frames",
                                    window),
        "estimator took": stage_rate(diagnostics, f"contact_estimation: {patch}",
                                     "frames_received", window),
        "controller got": len(arrived) / seconds,
    }
    print("    stages, frames/s: " + ", ".join(f"{k} {v:.1f}" for k, v in rates.items()))


def lost_stamps(published: np.ndarray, received: np.ndarray) -> list[int]:
    """Stamps of ``published`` (in publishing order) that are not among ``received``, which
    may hold them in any order, late, or more than once."""
    got = set(received.tolist())
    return [s for s in published.tolist() if s not in got]


def print_trace(i: int, sent: np.ndarray, records: Any, probe: Any,
                window: tuple[int, int]) -> None:
    """Link i counted by stamp, exactly (``--composed``: the estimator is probed): frames the
    board sent, the estimator took and published, and states the controller received, over the
    frames whose estimator hand-off lies inside the window; published but never received, and
    received but never published (stamps)."""
    inside = (sent[:, 1] >= window[0]) & (sent[:, 1] < window[1])
    taken = probe["taken"][probe["taken"][:, 0] == i]
    published = probe["published"][probe["published"][:, 0] == i]
    received = records["received"][records["received"][:, 0] == i]
    took = taken[(taken[:, 2] >= window[0]) & (taken[:, 2] < window[1])]
    pub = published[(published[:, 2] >= window[0]) & (published[:, 2] < window[1])]
    lost = lost_stamps(pub[:, 1], received[:, 1])
    pub_all = set(published[:, 1].tolist())
    extra = [s for s in received[:, 1].tolist()
             if s not in pub_all and window[0] <= s and s < window[1]]
    kept = received[received[:, 3] == 0]
    print(f"    by stamp: board sent {int(inside.sum())}, estimator took {len(took)} "
          f"({len(took) - len(set(took[:, 1].tolist()))} repeated stamps), published "
          f"{len(pub)}, of those never received by the controller {len(lost)}; received "
          f"but not published {len(extra)}; received but refused {len(kept)}")
    if lost:
        at = pub[np.isin(pub[:, 1], lost), 2]
        bursts = np.split(at, np.flatnonzero(np.diff(at) > 0.1e9) + 1)
        print("    lost in bursts (s into the window, states, ms): " + ", ".join(
            f"{(b[0] - window[0]) / 1e9:.2f} s {len(b)} over {(b[-1] - b[0]) / 1e6:.0f} ms"
            for b in bursts))


def print_pauses(records: Any, probe: Any, window: tuple[int, int]) -> None:
    """Whole-process pauses inside the window: full (generation-2) garbage collections and
    rclpy logger calls of the controller and, when probed, the composed process (count,
    longest [ms], s into the window), and the controller's longest control cycle."""
    def inside(rows: np.ndarray) -> np.ndarray:
        return rows[(rows[:, 0] >= window[0]) & (rows[:, 0] < window[1])]

    def longest(rows: np.ndarray) -> str:
        if not len(rows):
            return "0"
        k = int(np.argmax(rows[:, 1] - rows[:, 0]))
        return (f"{len(rows)}, longest {(rows[k, 1] - rows[k, 0]) / 1e6:.1f} ms at "
                f"{(rows[k, 0] - window[0]) / 1e9:.2f} s")

    for name, rec in (("controller", records), ("drivers+estimation", probe)):
        if rec is None or "gc" not in rec:
            continue
        full = inside(rec["gc"][rec["gc"][:, 2] == 2])
        extra = (f"; cycles: {longest(inside(rec['ticks']))}; inputs refused (whole run): "
                 f"{int(rec['rejected'])}") if "ticks" in rec else ""
        print(f"  pauses, {name}: full collections {longest(full)}; log calls "
              f"{longest(inside(rec['logs']))}{extra}")


def report(args: argparse.Namespace, sent: dict[int, tuple[np.ndarray, int]], records: Any,
           window: tuple[int, int], cpu: dict[str, float], busy_cores: float,
           diagnostics: list[tuple[int, str, dict[str, str]]] | None = None,
           probe: Any = None) -> None:
    """Print the results (see the module docstring)."""
    period_ns = 1e9 / args.rate
    markers = "off" if not args.markers else (
        f"≤ {args.marker_rate:g} Hz" if args.marker_rate > 0 else "with every state")
    layout = ("separate processes" if args.composed is None else
              f"drivers+estimation composed, taxel topics at {args.composed:g} Hz")
    seconds = (window[1] - window[0]) / 1e9
    print(f"\nchain: {args.boards} boards × {args.taxels} taxels at {args.rate:g} Hz → "
          f"skin_driver ×{args.boards} → contact_estimation (markers "
          f"{markers}) → wholebody_controller at "
          f"{args.controller_rate:g} Hz; executor '{args.executor}'; "
          f"{layout}; "
          f"{seconds:.1f} s measured")
    all_state, all_command = [], []
    n_sent = n_arrived = 0
    for i in range(args.boards):
        counts, to_state, to_command = analyse_link(i, sent[i][0], records, window, period_ns)
        n_sent, n_arrived = n_sent + counts["sent"], n_arrived + counts["arrived"]
        all_state.append(to_state)
        all_command.append(to_command)
        dropped = counts["sent"] - counts["arrived"]
        print(f"  {SKIN_LINKS[i]}: frames sent {counts['sent']} (board late skips, whole run: "
              f"{sent[i][1]}), dropped {dropped} ({100 * dropped / max(counts['sent'], 1):.2f} "
              f"%; of which cut off at the full pty: {counts['cut']}), used by a command "
              f"{counts['used']}, contact states matching no frame {counts['unmatched']}")
        if diagnostics is not None:
            print_stages(i, sent[i][0], records, window, diagnostics)
        if probe is not None:
            print_trace(i, sent[i][0], records, probe, window)
    print_pauses(records, probe, window)
    state_ns, command_ns = np.concatenate(all_state), np.concatenate(all_command)
    commands = records["commands"]
    n_cmd = int(((commands[:, 0] >= window[0]) & (commands[:, 0] < window[1])).sum())
    print(f"  frame end → contact state in the controller: {_ms(state_ns)}")
    print(f"  frame end → command computed from it:       {_ms(command_ns)}")
    print(f"  commands: {n_cmd / seconds:.1f} per second")
    print("  CPU, % of one core:")
    for name, share in cpu.items():
        print(f"    {name:28s} {100 * share:6.1f}")
    skin = sum(v for k, v in cpu.items()
               if k.split()[0] in ("skin_driver", "contact_estimation", "skin_contact_node"))
    chain = skin + cpu["wholebody_controller"]
    print(f"    {'chain (drivers+estimation+controller)':28s} {100 * chain:6.1f}")
    print(f"  CPU per frame delivered to the controller (drivers+estimation): "
          f"{1e6 * skin * seconds / max(n_arrived, 1):.0f} µs; controller CPU per command: "
          f"{1e6 * cpu['wholebody_controller'] * seconds / max(n_cmd, 1):.0f} µs")
    print(f"  machine: {busy_cores:.2f} of {os.cpu_count()} cores busy over the window "
          f"(all processes, other jobs included); {load_line()}")
    print("  row: | sent | dropped | frame end → command median / p99 | drivers+estimation | "
          "controller | per frame | busy cores | load (1 min) |")
    print(f"  row: | {n_sent} | {100 * (n_sent - n_arrived) / max(n_sent, 1):.1f} % | "
          f"{np.median(command_ns) / 1e6 if command_ns.size else float('nan'):.1f} / "
          f"{np.percentile(command_ns, 99) / 1e6 if command_ns.size else float('nan'):.1f} ms | "
          f"{100 * skin:.0f} % | {100 * cpu['wholebody_controller']:.0f} % | "
          f"{1e6 * skin * seconds / max(n_arrived, 1):.0f} µs | {busy_cores:.2f} | "
          f"{os.getloadavg()[0]:.1f} |")


def measure(args: argparse.Namespace, tmp: Path) -> None:
    """Start everything, measure the window, stop everything, report."""
    ctx = mp.get_context("fork")
    stop, queue = ctx.Event(), ctx.Queue()
    layouts = _write_layouts(tmp, args.boards, args.taxels)
    boards = [ctx.Process(target=_board_process, args=(i, str(tmp / f"port{i}"), str(f),
                                                       args.rate, stop, queue, args.priority,
                                                       args.transport))
              for i, f in enumerate(layouts)]
    for b in boards:
        b.start()
    procs = _start_nodes(tmp, layouts, args)
    inputs = Inputs(args.inputs_rate)
    try:
        ready = tmp / "controller.ready"
        if not inputs.run_until(ready.exists, 90.0):
            raise RuntimeError("the controller computed no command within 90 s of start-up")
        inputs.run_until(lambda: False, args.warmup)
        pids = {name: p.pid for name, p in procs.items()}
        pids.update({f"sim board {i}": int(b.pid or 0) for i, b in enumerate(boards)})
        pids["bench (joint states, odom)"] = os.getpid()
        cpu0, machine0, t0 = {k: process_cpu_s(p) for k, p in pids.items()}, MachineCpu.now(), \
            time.time_ns()
        inputs.run_until(lambda: False, args.seconds)
        cpu1, machine1, t1 = {k: process_cpu_s(p) for k, p in pids.items()}, MachineCpu.now(), \
            time.time_ns()
    finally:
        stop.set()
        sent = {}
        for _ in boards:
            i, frames, late = queue.get(timeout=30)
            sent[i] = (frames, late)
        for p in procs.values():
            p.send_signal(signal.SIGINT)
        for p in procs.values():
            p.wait(30)
        for b in boards:
            b.join(10)
        inputs.close()
    cpu = {k: (cpu1[k] - cpu0[k]) / ((t1 - t0) / 1e9) for k in pids}
    records = np.load(tmp / "controller.npz")
    if records["arrivals"].size == 0:
        raise RuntimeError("the controller probe recorded no contact state (is "
                           f"WholeBodyControllerNode still calling {PROBED_METHODS[0]}?)")
    probe = np.load(tmp / "composed.npz") if args.composed is not None else None
    if args.save:
        save = Path(args.save)
        save.mkdir(parents=True, exist_ok=True)
        np.savez(save / "sent.npz", window=np.array([t0, t1]),
                 **{f"sent{i}": frames for i, (frames, _late) in sent.items()})
        for name in ("controller.npz", "composed.npz"):
            if (tmp / name).exists():
                shutil.copy(tmp / name, save / name)
    report(args, sent, records, (t0, t1), cpu, machine1.busy_cores_since(machine0),
           inputs.diagnostics, probe)


def main(argv: Sequence[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    if argv and argv[0] == "--controller-probe":
        rest = argv[2:]
        return run_controller_probe(argv[1], rest[1:] if rest[:1] == ["--ros-args"] else rest)
    if argv and argv[0] == "--composed-probe":
        return run_composed_probe(argv[1], argv[2:])
    p = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    p.add_argument("--seconds", type=float, default=60.0, help="measured seconds")
    p.add_argument("--warmup", type=float, default=3.0, help="seconds ignored after start-up")
    p.add_argument("--boards", type=int, default=3, choices=(1, 2, 3))
    p.add_argument("--taxels", type=int, default=2000, help="taxels per board")
    p.add_argument("--rate", type=float, default=500.0, help="board frame rate [Hz]")
    p.add_argument("--controller-rate", type=float, default=500.0, help="[Hz]")
    p.add_argument("--inputs-rate", type=float, default=100.0,
                   help="joint state and odometry rate of this process [Hz]")
    p.add_argument("--executor", choices=EXECUTORS, default=EXECUTORS[0],
                   help="PHRI_EXECUTOR of the node processes (phri_common.ros_main)")
    p.add_argument("--composed", type=float, default=None, metavar="HZ",
                   help="drivers and estimation in one process (phri_bringup.skin_contact_node),"
                        " taxel topics published at HZ")
    p.add_argument("--marker-rate", type=float, default=30.0,
                   help="contact_estimation marker_rate_hz (0 = every state, as before 15)")
    p.add_argument("--no-markers", dest="markers", action="store_false",
                   help="contact_estimation publish_markers:=false")
    p.add_argument("--priority", type=int, default=0, choices=range(0, 100), metavar="0-99",
                   help="thread_priority of the skin drivers' and the controller's threads, "
                        "and SCHED_FIFO for the simulated boards (hardware); 0 = off")
    p.add_argument("--transport", choices=("pty", "socket"), default="pty",
                   help="how the simulated boards reach the drivers: a pty each (a USB serial "
                        "board; ≈ 20 KB of buffer, one 10,000-taxel frame) or a TCP "
                        "server each on localhost (an Ethernet board, socket:// URLs)")
    p.add_argument("--save", metavar="DIR", default=None,
                   help="keep the raw records (frames sent, probes) in DIR as .npz")
    args = p.parse_args(argv)
    isolate_ros_environment()
    print(load_line(), f"; thread_priority {args.priority}" if args.priority else "",
          f"; boards on {args.transport}")
    tmp = Path(tempfile.mkdtemp(prefix="bench_chain_"))
    try:
        measure(args, tmp)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
