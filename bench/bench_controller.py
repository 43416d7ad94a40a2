"""Benchmark: the full whole-body control step, side by side with mink's IK step (design §7).

1. ``full step``: contact estimation of 3 links × 2,000 taxels (``set_forces`` per patch +
   ``estimate``) followed by :meth:`WholeBodyController.step` with all three links in contact
   (three admittances + life-cycles, kinematics update + three contact-centre Jacobians, QP build
   and solve), for each QP backend; the same with 3 × 10,000 taxels; the controller step with
   its Python kernel (``kernel="python"``: the same functions interpreted); then the breakdown
   into stages (MuJoCo's kinematics, the QP solve),
   the estimation with the numpy reference kernel (``kernel="numpy"``, the code before the
   compiled one) for a same-run before/after, and the straightforward numpy reference step
   (``wholebody_controller/test/wbc_reference.py``, the implementation before the optimisation)
   for a same-load comparison.
2. ``mink``: ``mink.solve_ik`` on the same robot (same MuJoCo model, same joints) with three
   ``FrameTask``s on the same links, ``ConfigurationLimit`` and ``VelocityLimit``, with daqp and
   OSQP; timed per call including ``Configuration.update``.
3. ``node`` (``--node-seconds``; ``--node-only`` runs only this part): the controller node at
   500 Hz in this process, spun like ``phri_common.ros_main.run_nodes`` (``PHRI_EXECUTOR``,
   default events; 0.1 s slices, or ``--loop spin_once``), with its inputs (joint states,
   odometry, three contact states at 500 Hz) published by a separate peer process: loop period
   median, p99 of |period − 2 ms|, max, the tick's CPU time and the process's CPU (executor
   thread and DDS threads).

All cases are timed in interleaved rounds so that a change of machine load hits every row alike.
Run: ``.venv/bin/python bench/bench_controller.py [--repeats 3000] [--node-seconds 5]
[--node-only] [--loop slices|spin_once]``
Prints median and p99 in µs.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from contact_estimation.estimator import ContactEstimator, EstimatorConfig
from phri_common.procstat import load_line
from phri_common.records import ContactState
from skin_driver.layout import cylinder_taxels
from skin_driver.sim_board import pressed_block
from wholebody_controller.config import SKIN_LINKS, ControllerConfig
from wholebody_controller.controller import StepResult, WholeBodyController
from wholebody_controller.kinematics import RobotKinematics
from wholebody_controller.qp import make_solver

Q_HOME = np.array([0.0, 0.0, 0.0,
                   0.3, -1.2, 1.5, -1.0, -1.57, 0.0,
                   -0.3, -1.9, -1.5, -1.0, 1.57, 0.0])
CENTER = np.array([-0.15, 0.0, 0.05])
ROOT = Path(__file__).resolve().parents[1]

Case = Callable[[int], object]


def control_step(
    controller: WholeBodyController, q: np.ndarray, contacts: Mapping[str, ContactState]
) -> StepResult:
    """The control step from contact states to the command (what the node runs)."""
    return controller.step(q, contacts)


def contacts_for(k: int) -> dict[str, ContactState]:
    """Three touched links with slowly varying force and a slide (track force appears)."""
    out = {}
    for i, link in enumerate(SKIN_LINKS):
        phase = 0.01 * k + i
        centre = CENTER + np.array([0.03 * np.sin(phase), 0.0, 0.0])
        force = np.array([3.0 * np.cos(phase), 2.0, -8.0 - 2.0 * np.sin(phase)])
        out[link] = ContactState(link, k, True, centre, force, np.array([0.0, 0.3, 0.1]),
                                 centre - 0.02, centre + 0.02, 200)
    return out


class SkinFrames:
    """Contact estimation inputs: 3 cylinder patches of n taxels, a pressed area that slides."""

    def __init__(self, taxels: int, frames: int = 64, kernel: str = "numba") -> None:
        rng = np.random.default_rng(0)
        self.estimator = ContactEstimator({f"p{i}": link for i, link in enumerate(SKIN_LINKS)},
                                          EstimatorConfig(kernel=kernel))
        positions, normals = cylinder_taxels(taxels)
        for patch in self.estimator_patches:
            self.estimator.set_geometry(patch, positions, normals)
        # A pressed band (10 % of the patch) moving along the sequence: the centre slides.
        base = pressed_block(taxels, 0.1, rng)
        self.forces = [np.roll(base, 3 * k) for k in range(frames)]

    @property
    def estimator_patches(self) -> tuple[str, ...]:
        return tuple(f"p{i}" for i in range(len(SKIN_LINKS)))

    def estimate(self, k: int) -> dict[str, ContactState]:
        """One control step's contact estimation: new forces on every patch, one estimate."""
        forces = self.forces[k % len(self.forces)]
        for patch in self.estimator_patches:
            self.estimator.set_forces(patch, forces, k)
        return self.estimator.estimate()


def stats(samples_ns: np.ndarray) -> tuple[float, float]:
    return float(np.median(samples_ns)) / 1e3, float(np.percentile(samples_ns, 99)) / 1e3


def time_cases(cases: dict[str, Case], repeats: int, rounds: int = 10) -> dict[str, tuple]:
    """Median and p99 [µs] of each case, timed in interleaved rounds (after a warm-up)."""
    for fn in cases.values():
        for k in range(min(200, repeats)):
            fn(k)
    samples = {name: np.empty(repeats) for name in cases}
    chunk = max(1, repeats // rounds)
    done = 0
    while done < repeats:
        end = min(repeats, done + chunk)
        for name, fn in cases.items():
            out = samples[name]
            for k in range(done, end):
                t0 = time.perf_counter_ns()
                fn(k)
                out[k] = time.perf_counter_ns() - t0
        done = end
    return {name: stats(s) for name, s in samples.items()}


def row(name: str, result: tuple[float, float]) -> None:
    print(f"| {name:<62} | {result[0]:>9.1f} | {result[1]:>9.1f} |")


def controller_cases(repeats: int) -> dict[str, Case]:
    contact_seq = [contacts_for(k) for k in range(repeats + 200)]
    cases: dict[str, Case] = {}
    skin = {n: SkinFrames(n) for n in (2_000, 10_000)}
    numpy_skin = {n: SkinFrames(n, kernel="numpy") for n in (2_000, 10_000)}

    def stepper(solver: str, taxels: int | None, kernel: str = "numba",
                step_kernel: str = "numba") -> Case:
        ctl = WholeBodyController(RobotKinematics(),
                                  ControllerConfig(solver=solver, kernel=step_kernel))
        state = {"q": Q_HOME.copy()}
        frames = skin if kernel == "numba" else numpy_skin

        def step(k: int) -> None:
            contacts = frames[taxels].estimate(k) if taxels else contact_seq[k]
            res = control_step(ctl, state["q"], contacts)
            state["q"] = state["q"] + 0.002 * res.qdot

        return step

    cases["full step: estimation 3×2,000 + controller, daqp"] = stepper("daqp", 2_000)
    cases["full step: estimation 3×2,000 + controller, osqp"] = stepper("osqp", 2_000)
    cases["full step: estimation 3×10,000 + controller, daqp"] = stepper("daqp", 10_000)
    cases["full step, controller with the python kernel (interpreted), 3×2,000"] = stepper(
        "daqp", 2_000, step_kernel="python")
    cases["full step, estimation, numpy reference sums, 3×2,000"] = stepper(
        "daqp", 2_000, "numpy")
    cases["full step, estimation, numpy reference sums, 3×10,000"] = stepper(
        "daqp", 10_000, "numpy")
    cases["  contact estimation, 3 × 2,000 taxels"] = skin[2_000].estimate
    cases["  contact estimation, 3 × 10,000 taxels"] = skin[10_000].estimate
    cases["  contact estimation, 3 × 2,000 taxels, numpy reference sums"] = (
        numpy_skin[2_000].estimate)
    cases["  controller step (3 links in contact), daqp"] = stepper("daqp", None)
    cases["  controller step, python kernel (interpreted), daqp"] = stepper(
        "daqp", None, step_kernel="python")
    cases.update(compiled_breakdown(contact_seq))

    # The straightforward numpy step (the implementation before the optimisation).
    sys.path.insert(0, str(ROOT / "wholebody_controller" / "test"))
    from wbc_reference import RefController

    ref = RefController(RobotKinematics(), ControllerConfig())
    ref_state = {"q": Q_HOME.copy()}

    def ref_step(k: int) -> None:
        out = ref.step(ref_state["q"], contact_seq[k])
        ref_state["q"] = ref_state["q"] + 0.002 * out.qdot

    cases["  reference step (straightforward numpy), daqp"] = ref_step
    return cases


def compiled_breakdown(contact_seq: list[dict[str, ContactState]]) -> dict[str, Case]:
    """The compiled step's parts: MuJoCo's kinematics alone, the QP solve alone (daqp) — the
    rest of a step is the one kernel call (tasks, Jacobians, QP build) and its packing."""
    kin = RobotKinematics()
    ctl = WholeBodyController(kin)
    res = ctl.step(Q_HOME, contact_seq[0])
    solver = make_solver("daqp")

    def kinematics(_k: int) -> None:
        kin.data.qpos[:] = Q_HOME
        mujoco.mj_kinematics(kin.model, kin.data)

    def solve(_k: int) -> None:
        solver.solve(res.problem)

    return {"    compiled: MuJoCo kinematics (mj_kinematics)": kinematics,
            "    compiled: QP solve, daqp": solve}


def mink_cases() -> dict[str, Case]:
    import mink

    kin = RobotKinematics()
    model = kin.model
    # mink's ConfigurationLimit reads jnt_range: it must hold the description's limits [rad].
    ranges = np.asarray(kin.position_limits)
    for i, name in enumerate(kin.joint_names):
        if np.all(np.isfinite(ranges[i])):
            assert np.allclose(model.jnt_range[model.joint(name).id], ranges[i]), name
    cases: dict[str, Case] = {}
    for solver in ("daqp", "osqp"):
        configuration = mink.Configuration(model)
        configuration.update(Q_HOME)
        tasks = []
        for link in SKIN_LINKS:
            task = mink.FrameTask(link, "body", position_cost=1.0, orientation_cost=1.0)
            target = configuration.get_transform_frame_to_world(link, "body")
            shifted = mink.SE3.from_rotation_and_translation(
                target.rotation(), target.translation() + np.array([0.02, -0.01, 0.01])
            )
            task.set_target(shifted)
            tasks.append(task)
        velocities = dict.fromkeys(kin.joint_names, 0.15)
        limits = [mink.ConfigurationLimit(model), mink.VelocityLimit(model, velocities)]
        state = {"q": Q_HOME.copy()}

        def step(_k: int, c: Any = configuration, t: list = tasks, lim: list = limits,
                 s: str = solver, st: dict = state) -> None:
            c.update(st["q"])
            v = mink.solve_ik(c, t, 0.01, s, damping=1e-3, limits=lim)
            st["q"] = st["q"] + 0.002 * v

        cases[f"mink solve_ik, 3 frame tasks + limits, {solver}"] = step
    return cases


# -- node mode ------------------------------------------------------------------------------------
def run_peer(seconds: float) -> None:
    """Peer process: publish the controller's inputs at 500 Hz for ``seconds``."""
    import rclpy
    from nav_msgs.msg import Odometry
    from sensor_msgs.msg import JointState, PointCloud2

    from phri_common.contact import contact_to_msg
    from phri_common.testing import isolate_ros_environment
    from wholebody_controller.kinematics import JOINT_NAMES

    isolate_ros_environment()
    rclpy.init()
    peer = rclpy.create_node("bench_controller_peer")  # SIGTERM from the bench ends it
    joints_pub = peer.create_publisher(JointState, "/joint_states", 10)
    odom_pub = peer.create_publisher(Odometry, "/odom", 10)
    pubs = {link: peer.create_publisher(PointCloud2, f"contacts/{link}", 10)
            for link in SKIN_LINKS}
    names, arm = list(JOINT_NAMES[3:]), Q_HOME[3:].tolist()
    end = time.monotonic() + seconds
    next_t = time.monotonic()
    k = 0
    while time.monotonic() < end and rclpy.ok():
        k += 1
        joints_pub.publish(JointState(name=names, position=arm))
        odom = Odometry()
        odom.pose.pose.orientation.w = 1.0
        odom_pub.publish(odom)
        try:
            for link, state in contacts_for(k).items():
                pubs[link].publish(contact_to_msg(state))
        except Exception:  # terminated by the bench (SIGTERM shut the context down)
            return
        next_t += 0.002
        delay = next_t - time.monotonic()
        if delay > 0:
            time.sleep(delay)
    peer.destroy_node()
    rclpy.try_shutdown()


def bench_node(seconds: float, loop: str = "slices", control_loop: str = "auto",
               thread_priority: int = 0) -> None:
    """The controller node at 500 Hz in this process (module docstring, 3.), spun in 0.1 s
    slices as ``run_nodes`` (``loop="slices"``) or with one ``spin_once`` per callback, its
    cycle run by its own thread or an executor timer (``control_loop``; "auto" is the node's
    default, also on trees without the parameter)."""
    import rclpy
    from rclpy.parameter import Parameter

    from phri_common import ros_main
    from phri_common.ros_main import EXECUTOR_ENV, EXECUTORS, make_executor
    from phri_common.testing import isolate_ros_environment
    from wholebody_controller.node import WholeBodyControllerNode

    domain = isolate_ros_environment()
    context = rclpy.Context()
    rclpy.init(context=context, domain_id=domain)
    ticks: list[int] = []
    busy: list[int] = []  # CPU time of each tick [ns] (the ticking thread)
    cycle_cpu: list[int] = []  # CPU time of the ticking thread at each tick's start [ns]

    class TimedNode(WholeBodyControllerNode):
        def tick(self) -> None:
            ticks.append(time.perf_counter_ns())
            t0 = time.thread_time_ns()
            cycle_cpu.append(t0)
            super().tick()
            busy.append(time.thread_time_ns() - t0)

    overrides: list[Parameter[Any]] = [Parameter("rate_hz", value=500.0)]
    if control_loop != "auto":
        overrides.append(Parameter("control_loop", value=control_loop))
    if thread_priority:
        overrides.append(Parameter("thread_priority", value=thread_priority))
    node = TimedNode(context=context, parameter_overrides=overrides)
    mode = getattr(node, "control_loop", "timer")
    peer = subprocess.Popen([sys.executable, __file__, "--peer", str(seconds + 70.0)])
    executor = make_executor(context=context)  # PHRI_EXECUTOR, as run_nodes

    def spin() -> None:
        if loop == "slices":
            ros_main.spin_slice(executor)  # (looked up here: the spin_once loop runs on trees
            # without it, for a same-run before/after)
        else:
            executor.spin_once(timeout_sec=0.1)

    executor.add_node(node)
    # The peer process needs seconds to start on a loaded machine: wait for good cycles.
    deadline = time.monotonic() + 60.0
    while node.good_cycles < 500 and time.monotonic() < deadline:
        executor.spin_once(timeout_sec=0.1)
    if node.good_cycles < 500:
        print("\nnode: the input peer did not come up within 60 s")
    start, good0, zero0 = len(ticks), node.good_cycles, node.zero_cycles
    cpu0, main0, wall0 = time.process_time(), time.thread_time(), time.monotonic()
    while time.monotonic() < wall0 + seconds:
        spin()
    wall = time.monotonic() - wall0
    cpu, main = (time.process_time() - cpu0) / wall, (time.thread_time() - main0) / wall
    end = len(ticks)
    periods = np.diff(np.array(ticks[start:end])) / 1e6  # ms
    # The control thread's CPU over the window (its thread_time at the first and last tick).
    control = (cycle_cpu[end - 1] - cycle_cpu[start]) / 1e9 / wall if mode == "thread" else 0.0
    tick_us = np.array(busy[start:end]) / 1e3
    good, zero = node.good_cycles - good0, node.zero_cycles - zero0
    peer.terminate()
    peer.wait(timeout=10)
    executor.shutdown()
    node.destroy_node()
    context.try_shutdown()
    jitter = np.abs(periods - 2.0)
    kind = os.environ.get(EXECUTOR_ENV) or EXECUTORS[0]
    per_period = 2e-3 * 1e6  # µs of CPU per 2 ms period per unit of "share of a core"
    print(f"\nnode at 500 Hz over {seconds:.0f} s (control_loop '{mode}', thread_priority "
          f"{thread_priority}, executor '{kind}', "
          f"loop '{loop}', inputs "
          f"from a peer process): {len(periods)} periods, median {np.median(periods):.3f} ms, "
          f"jitter p99 {np.percentile(jitter, 99):.3f} ms, max {np.max(periods):.3f} ms; control "
          f"cycles {good} good / {zero} zero; tick callback CPU median {np.median(tick_us):.0f} "
          f"µs, p99 {np.percentile(tick_us, 99):.0f} µs; process CPU {100 * cpu:.0f} % of one "
          f"core ({cpu * per_period:.0f} µs per period: executor thread {main * per_period:.0f}, "
          f"control thread {control * per_period:.0f}, DDS threads "
          f"{(cpu - main - control) * per_period:.0f}; {1e6 * cpu * wall / len(periods):.0f} "
          "µs per tick run)")


def main() -> None:
    parser = argparse.ArgumentParser(description=(__doc__ or "").split("\n")[0])
    parser.add_argument("--repeats", type=int, default=3000)
    parser.add_argument("--node-seconds", type=float, default=5.0)
    parser.add_argument("--skip-node", action="store_true")
    parser.add_argument("--node-only", action="store_true", help="only the node part (3.)")
    parser.add_argument("--loop", choices=("slices", "spin_once"), default="slices",
                        help="how the node part drives the executor (default: as run_nodes)")
    parser.add_argument("--control-loop", choices=("auto", "thread", "timer"), default="auto",
                        help="the node's control_loop (default: its own default, thread)")
    parser.add_argument("--thread-priority", type=int, default=0,
                        help="the node's thread_priority (SCHED_FIFO 1–99; default 0: off)")
    parser.add_argument("--peer", type=float, default=None, help=argparse.SUPPRESS)
    args = parser.parse_args()
    print(load_line())
    if args.peer is not None:
        run_peer(args.peer)
        return
    if args.node_only:
        bench_node(args.node_seconds, args.loop, args.control_loop, args.thread_priority)
        return
    cases = controller_cases(args.repeats)
    cases.update(mink_cases())
    results = time_cases(cases, args.repeats)
    print(f"{args.repeats} steps per case, interleaved rounds; times in µs")
    print(f"| {'step':<62} | median µs |    p99 µs |")
    print(f"|{'-' * 64}|----------:|----------:|")
    for name, result in results.items():
        row(name, result)
    if not args.skip_node:
        bench_node(args.node_seconds, args.loop, args.control_loop, args.thread_priority)


if __name__ == "__main__":
    main()
