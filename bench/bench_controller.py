"""Benchmark: the whole-body control step, side by side with mink's IK step (design §7).

1. ``controller``: one :meth:`WholeBodyController.step` with all three skin links in contact
   (three admittances + life-cycles, kinematics update + three contact-centre Jacobians, QP build
   and solve), for each QP backend, plus a breakdown of its parts. Contact estimation on
   3 × 2,000 taxels is not included here: :func:`control_step` takes ready ``ContactState``s, so
   the estimator's per-step cost (``bench_contact_estimation.py``) adds on top.
2. ``mink``: ``mink.solve_ik`` on the same robot (same MuJoCo model, same joints) with three
   ``FrameTask``s on the same links, ``ConfigurationLimit`` and ``VelocityLimit``, with daqp and
   OSQP; timed per call including ``Configuration.update``.
3. ``node``: the ROS node at 500 Hz (EventsExecutor, inputs published at 500 Hz by a peer node in
   the same process): loop period median, p99 of |period − 2 ms|, max.

Run: ``.venv/bin/python bench/bench_controller.py [--repeats 3000] [--node-seconds 5]``
Prints median and p99 in µs.
"""

from __future__ import annotations

import argparse
import threading
import time
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np

from phri_common.contact import ContactState
from wholebody_controller.config import SKIN_LINKS, ControllerConfig
from wholebody_controller.controller import StepResult, WholeBodyController
from wholebody_controller.kinematics import RobotKinematics
from wholebody_controller.qp import QPSolver, build_qp, make_solver, velocity_bounds

Q_HOME = np.array([0.0, 0.0, 0.0,
                   0.3, -1.2, 1.5, -1.0, -1.57, 0.0,
                   -0.3, -1.9, -1.5, -1.0, 1.57, 0.0])
CENTER = np.array([-0.15, 0.0, 0.05])


def control_step(
    controller: WholeBodyController, q: np.ndarray, contacts: Mapping[str, ContactState]
) -> StepResult:
    """The full control step from contact states to the command (what the node runs)."""
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


def stats(samples_ns: np.ndarray) -> tuple[float, float]:
    return float(np.median(samples_ns)) / 1e3, float(np.percentile(samples_ns, 99)) / 1e3


def timeit(fn: Callable[[int], object], repeats: int) -> tuple[float, float]:
    for k in range(min(200, repeats)):
        fn(k)
    samples = np.empty(repeats)
    for k in range(repeats):
        t0 = time.perf_counter_ns()
        fn(k)
        samples[k] = time.perf_counter_ns() - t0
    return stats(samples)


def row(name: str, result: tuple[float, float]) -> None:
    print(f"| {name:<52} | {result[0]:>9.1f} | {result[1]:>9.1f} |")


def bench_controller(repeats: int) -> None:
    contact_seq = [contacts_for(k) for k in range(repeats + 200)]
    for solver in ("daqp", "osqp"):
        kin = RobotKinematics()
        ctl = WholeBodyController(kin, ControllerConfig(solver=solver))
        state = {"q": Q_HOME.copy()}

        def step(k: int, ctl: WholeBodyController = ctl, state: dict = state) -> None:
            res = control_step(ctl, state["q"], contact_seq[k])
            state["q"] = state["q"] + 0.01 * res.qdot

        row(f"control step, 3 links in contact, {solver}", timeit(step, repeats))

    # Breakdown (daqp).
    kin = RobotKinematics()
    ctl = WholeBodyController(kin)
    res = ctl.step(Q_HOME, contact_seq[0])
    points = [t.point for t in res.tasks]

    def kinematics(_k: int) -> None:
        kin.update(Q_HOME)
        for link, point in zip(SKIN_LINKS, points, strict=True):
            kin.link_pose(link)
            kin.point_jacobian(link, point)

    row("  kinematics: update + 3 poses + 3 point Jacobians", timeit(kinematics, repeats))
    kin.update(Q_HOME)
    poses = [kin.link_pose(link) for link in SKIN_LINKS]

    def tasks(k: int) -> None:
        cs = contact_seq[k]
        for task, (rot, pos) in zip(ctl.tasks, poses, strict=True):
            task.update(cs[task.config.link], rot, pos, 0.0)

    row("  3 tasks: (10)-(20) + Algorithm 1", timeit(tasks, repeats))
    jacs = [kin.point_jacobian(link, p) for link, p in zip(SKIN_LINKS, points, strict=True)]
    targets = [t.target for t in res.tasks]
    weights = [max(t.psi, 0.3) for t in res.tasks]

    def build(_k: int) -> None:
        lo, hi = velocity_bounds(Q_HOME, ctl.position_lower, ctl.position_upper,
                                 ctl.velocity_lower, ctl.velocity_upper, 0.15)
        build_qp(jacs, targets, weights, 0.1, lo, hi)

    row("  QP build (22)-(23)", timeit(build, repeats))
    lo, hi = velocity_bounds(Q_HOME, ctl.position_lower, ctl.position_upper,
                             ctl.velocity_lower, ctl.velocity_upper, 0.15)
    problem = build_qp(jacs, targets, weights, 0.1, lo, hi)
    for name in ("daqp", "osqp"):
        solver = make_solver(name)

        def solve(_k: int, s: QPSolver = solver) -> None:
            s.solve(problem)

        row(f"  QP solve, {name}", timeit(solve, repeats))


def bench_mink(repeats: int) -> None:
    import mink

    kin = RobotKinematics()
    model = kin.model
    # The compiled model's ranges must equal the description's limits for ConfigurationLimit.
    # (phri_description's model currently reads them as degrees: ±0.11 rad; fix them here.)
    limits_rad = np.asarray(kin.position_limits)
    for i, name in enumerate(kin.joint_names):
        jid = model.joint(name).id
        if np.all(np.isfinite(limits_rad[i])):
            model.jnt_range[jid] = limits_rad[i]
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
            st["q"] = st["q"] + 0.01 * v

        row(f"mink solve_ik, 3 frame tasks + limits, {solver}", timeit(step, repeats))


def bench_node(seconds: float) -> None:
    import rclpy
    from geometry_msgs.msg import Twist
    from nav_msgs.msg import Odometry
    from rclpy.experimental.events_executor import EventsExecutor
    from rclpy.parameter import Parameter
    from sensor_msgs.msg import JointState, PointCloud2

    from phri_common.contact import contact_to_msg
    from phri_common.testing import isolate_ros_environment
    from wholebody_controller.node import WholeBodyControllerNode

    domain = isolate_ros_environment()
    context = rclpy.Context()
    rclpy.init(context=context, domain_id=domain)
    ticks: list[int] = []

    class TimedNode(WholeBodyControllerNode):
        def tick(self) -> None:
            ticks.append(time.perf_counter_ns())
            super().tick()

    node = TimedNode(context=context, parameter_overrides=[Parameter("rate_hz", value=500.0)])
    peer = rclpy.node.Node("bench_peer", context=context)
    joints_pub = peer.create_publisher(JointState, "/joint_states", 10)
    odom_pub = peer.create_publisher(Odometry, "/odom", 10)
    contact_pubs = {
        link: peer.create_publisher(PointCloud2, f"contacts/{link}", 10) for link in SKIN_LINKS
    }
    commands: list[int] = []
    peer.create_subscription(Twist, "/cmd_vel", lambda _m: commands.append(1), 10)
    arm = list(Q_HOME[3:])
    names = list(node.arm_joints)
    counter = {"k": 0}

    def publish() -> None:
        k = counter["k"] = counter["k"] + 1
        joints_pub.publish(JointState(name=names, position=arm))
        odom = Odometry()
        odom.pose.pose.orientation.w = 1.0
        odom_pub.publish(odom)
        for link, msg in contacts_for(k).items():
            contact_pubs[link].publish(contact_to_msg(msg))

    peer.create_timer(0.002, publish)
    executor = EventsExecutor(context=context)
    executor.add_node(node)
    executor.add_node(peer)
    thread = threading.Thread(target=executor.spin, daemon=True)
    thread.start()
    time.sleep(1.0)  # warm-up
    start = len(ticks)
    time.sleep(seconds)
    periods = np.diff(np.array(ticks[start:])) / 1e6  # ms
    good, zero = node.good_cycles, node.zero_cycles
    executor.shutdown()
    node.destroy_node()
    peer.destroy_node()
    context.try_shutdown()
    jitter = np.abs(periods - 2.0)
    print(f"\nnode at 500 Hz over {seconds:.0f} s: {len(periods)} periods, "
          f"median {np.median(periods):.3f} ms, jitter p99 {np.percentile(jitter, 99):.3f} ms, "
          f"max {np.max(periods):.3f} ms; control cycles {good} good / {zero} zero; "
          f"{len(commands)} /cmd_vel received")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--repeats", type=int, default=3000)
    parser.add_argument("--node-seconds", type=float, default=5.0)
    parser.add_argument("--skip-node", action="store_true")
    args = parser.parse_args()
    print("| step | median µs | p99 µs |")
    print("|---|---:|---:|")
    bench_controller(args.repeats)
    bench_mink(args.repeats)
    if not args.skip_node:
        bench_node(args.node_seconds)


if __name__ == "__main__":
    main()
