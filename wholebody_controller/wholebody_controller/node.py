"""ROS 2 node around :class:`~wholebody_controller.controller.WholeBodyController` (thin).

Subscribes ``contacts/<link>`` (contact states), ``/joint_states``, ``/odom`` and each arm's UR
speed scaling (``<arm>/speed_scaling_state_broadcaster/speed_scaling``, ur_robot_driver's topic);
at ``rate_hz`` one control cycle publishes ``/cmd_vel``, ``left/…`` and
``right/forward_velocity_controller/commands`` and ``~/state/<link>``. Speed scaling (the
teach pendant's slider slows a UR's joints, not the base): below ``min_speed_scaling`` the cycle
commands zero and warns; otherwise the step's command is scaled after the step so that every
axis moves at the slowest arm's fraction (:func:`scale_to_slowest`). Safety (design §8): any
input older than its timeout, a QP failure, or a refused (NaN) input leads to a zero command in
that cycle; the next good cycle recovers; shutdown publishes zero. The freshness rules live in
:mod:`wholebody_controller.freshness`: the node reports arrivals and asks it once per cycle. See
``docs/wholebody_controller.md``.

Time. Input ages are measured with the node's clock (``get_clock()``), the same clock that drives
the control cycle: wall (ROS) time normally (read as ``time.time_ns()`` in ``control_loop:
thread``), simulation time from ``/clock`` when ``use_sim_time`` is true. In the simulator's
lock-step mode an input is therefore stale only when *simulated* time has run past its timeout,
never because the host was slow, which keeps runs deterministic on a loaded machine.

Control loop (``control_loop``). ``thread`` (the default on wall time): a thread of its own
(:class:`phri_common.periodic.PeriodicThread`) wakes at absolute deadlines, takes every input
queued since the last cycle from the subscriptions (:mod:`phri_common.polled`, in arrival order,
through the same callbacks) and runs the cycle: one wake-up per period instead of one executor
event per message (``bench/bench_controller.py --node-only``). ``timer``: an executor timer and
callbacks per message (the default under ``use_sim_time``: it follows ``/clock``). Services,
parameter changes and diagnostics run in the executor's thread under the node's cycle lock. If a
cycle raises unexpectedly, the thread publishes zero, reports ERROR on diagnostics, sets
``fatal_error`` and the process exits with code 1 (``run_nodes``), as an exception escaping a
timer callback ends the process in ``timer`` mode.
"""

from __future__ import annotations

import sys
import threading
import time
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import Twist
from nav_msgs.msg import Odometry
from numpy.typing import NDArray
from rclpy.node import Node
from rclpy.qos import QoSProfile, qos_profile_sensor_data
from rclpy.serialization import deserialize_message
from sensor_msgs.msg import JointState, PointCloud2
from std_msgs.msg import Float64, Float64MultiArray
from std_srvs.srv import Trigger

from phri_common.cdr import (
    CdrError,
    Float64ArrayEncoder,
    joint_state_arrays_from_cdr,
    odometry_pose_from_cdr,
    twist_to_cdr,
)
from phri_common.contact import ContactMessageError, msg_to_contact
from phri_common.contact_cdr import contact_from_cdr
from phri_common.params import ParamValue
from phri_common.periodic import PeriodicThread
from phri_common.polled import PolledSubscription
from phri_common.records import ContactState
from phri_common.ros_main import run_nodes, timer_callback
from phri_common.ros_params import declare_parameters
from phri_common.stamps import ns_to_stamp
from wholebody_controller.contact_safety import Safety, safety_changed
from wholebody_controller.controller import KinematicsModel, WholeBodyController
from wholebody_controller.freshness import InputFreshness
from wholebody_controller.input_checks import (
    InputError,
    check_contact_force,
    check_joint_positions,
    check_odometry_jump,
)
from wholebody_controller.kinematics import RobotKinematics
from wholebody_controller.messages import (
    SPEED_SCALING_TOPIC,
    loop_status,
    odom_to_base,
    pose_to_base,
    positions_by_name,
    robot_statuses,
    safety_status,
    speed_scaling_fraction,
    task_state_to_cdr,
)
from wholebody_controller.parameters import (
    GLOBAL_PARAMS,
    LINKS_PARAM,
    config_from_values,
    control_loop_mode,
    freshness_config,
    iso_overrides,
    link_param_specs,
    skin_check_config,
    torque_guard_config,
)
from wholebody_controller.qos import CONTACT_QOS, SCALING_QOS
from wholebody_controller.qp import QPError
from wholebody_controller.safe_stop import SafeStop
from wholebody_controller.skin_torque_check import SkinTorqueCheck
from wholebody_controller.speed_scaling import ARM_COMMAND_SLICES, ScalingGate, scale_to_slowest
from wholebody_controller.torque_guard import TorqueWatch


class WholeBodyControllerNode(Node):
    """The whole-body controller node. ``direct_state_inputs=True``: its owner calls
    :meth:`on_joints` / :meth:`on_odom` itself (phri_sim's lock-step runner), so the node
    subscribes neither ``/joint_states`` nor ``/odom``."""

    def __init__(
        self,
        *,
        kinematics: KinematicsModel | None = None,
        node_name: str = "wholebody_controller",
        clock_ns: Callable[[], int] | None = None,
        direct_state_inputs: bool = False,
        **kwargs: Any,
    ) -> None:
        """``clock_ns`` replaces the node clock [ns] (tests drive the cycle by hand with it)."""
        super().__init__(node_name, **kwargs)
        # Held by every control cycle and by whatever runs in the executor's thread beside it.
        self.cycle_lock = threading.RLock()
        self.fatal_error: BaseException | None = None  # what stopped the control thread
        # Before anything can fail: rclpy destroys even a node whose constructor raised.
        self.loop: PeriodicThread | None = None
        self._polled: list[tuple[PolledSubscription, Callable[[bytes], None]]] = []
        self.kinematics = kinematics if kinematics is not None else RobotKinematics()
        joints = list(self.kinematics.joint_names)
        self.arm_joints: tuple[str, ...] = tuple(joints[3:])
        self.left_joints, self.right_joints = self.arm_joints[0:6], self.arm_joints[6:12]
        if len(self.arm_joints) != 12:
            raise ValueError(f"expected 12 arm joints, got {self.arm_joints}")
        links_values = declare_parameters(self, [LINKS_PARAM])
        self.links: tuple[str, ...] = tuple(str(x) for x in links_values["links"])
        specs = [*GLOBAL_PARAMS, *(s for link in self.links for s in link_param_specs(link))]
        self.controller: WholeBodyController | None = None
        self.params = declare_parameters(self, specs, self._on_params)
        for text in iso_overrides(self.params, self.links):  # docs: Protected settings
            self.get_logger().error(f"iso15066_override: {text}")  # above ISO/TS 15066's table
        # When each input arrived (node clock) and whether a cycle may use them.
        self.freshness = InputFreshness(self.links, self.arm_joints,
                                        freshness_config(self.params))
        self.controller = WholeBodyController(self.kinematics, self._config(self.params))
        use_sim_time = bool(self.get_parameter("use_sim_time").value)
        self.control_loop = control_loop_mode(str(self.params["control_loop"]), use_sim_time)
        """``thread`` or ``timer`` (module docstring)."""

        self.clock_ns: Callable[[], int] = clock_ns or self._node_clock_ns()
        """The node clock [ns] (see the module docstring)."""
        self._init_inputs(joints)
        self._create_interfaces(direct_state_inputs)
        self._start_loop()

    def _init_inputs(self, joints: list[str]) -> None:
        """The latest inputs, the per-link safety states, the speed scaling and the counters."""
        # Latest inputs.
        self.contacts: dict[str, ContactState] = {}
        self.arm_q = np.zeros(12)
        self.base_q = np.zeros(3)
        self._last_odom: list[float] | None = None  # last odometry received, refused or not
        limits = np.asarray(self.kinematics.position_limits, dtype=np.float64)
        self.joint_limits = {name: (float(limits[i, 0]), float(limits[i, 1]))
                             for i, name in enumerate(joints) if name in self.arm_joints}
        self.safety: dict[str, Safety] = dict.fromkeys(self.links, Safety.OK)
        self.safe_stop = SafeStop()  # latched plausibility verdicts: exact zero until ~/reset
        self.speed_scaling: dict[str, float] = {}
        """Executed fraction of commanded speed per arm (0–1), from its UR; none: unscaled."""
        self.scaling_gate = ScalingGate()
        # Counters (diagnostics and tests).
        self.rejected_inputs = self.qp_failures = self.zero_cycles = self.good_cycles = 0

    def _node_clock_ns(self) -> Callable[[], int]:
        """The node clock [ns]: the control thread runs on the wall clock, which is what the
        node clock reads without simulation time, read directly (far cheaper than rclpy's clock,
        six reads a cycle); the timer mode reads the node clock (``/clock`` under
        ``use_sim_time``)."""
        if self.control_loop == "thread":
            return time.time_ns
        node_clock = self.get_clock()
        return lambda: node_clock.now().nanoseconds

    def _start_loop(self) -> None:
        """Start the control thread (``control_loop: thread``); warn if its priority was refused."""
        if self.loop is None:
            return
        self.loop.start()
        if self.loop.priority_error is not None:
            self.get_logger().warning(f"thread_priority: {self.loop.priority_error}; the "
                                      "control thread runs under the normal scheduler")

    def _create_interfaces(self, direct_state_inputs: bool) -> None:
        """Publishers, subscriptions (no state topics for ``direct_state_inputs``), services and
        timers (see the module docstring)."""
        self.torque_watch = TorqueWatch(torque_guard_config(self.params),  # contacts no skin feels
                                        self.kinematics.position_limits)
        self.skin_check = SkinTorqueCheck(skin_check_config(self.params))  # skin vs the joints
        # Commands are published as serialized bytes (phri_common.cdr): same messages, without
        # building three message objects per cycle.
        self._arm_encoders = (Float64ArrayEncoder(",".join(self.left_joints), 6),
                              Float64ArrayEncoder(",".join(self.right_joints), 6))
        self.cmd_pub = self.create_publisher(Twist, "/cmd_vel", 10)
        self.left_pub = self.create_publisher(
            Float64MultiArray, "left/forward_velocity_controller/commands", 10
        )
        self.right_pub = self.create_publisher(
            Float64MultiArray, "right/forward_velocity_controller/commands", 10
        )
        self.state_pubs = {
            link: self.create_publisher(PointCloud2, f"~/state/{link}", 10) for link in self.links
        }
        # Serialized bytes: contact states decoded without rclpy's PointField objects
        # (phri_common.contact_cdr; other layouts take the full path of on_contact), joint
        # states and odometry by phri_common.cdr (the few fields used).
        inputs: list[tuple[Any, str, Callable[[bytes], None], QoSProfile]] = [
            (PointCloud2, f"contacts/{link}",
             self._contact_handler(link), CONTACT_QOS)
            for link in self.links
        ]
        if not direct_state_inputs:
            inputs += [(JointState, "/joint_states", self.on_joints_bytes, qos_profile_sensor_data),
                       (Odometry, "/odom", self.on_odom_bytes, qos_profile_sensor_data)]
        inputs += [(Float64, f"{arm}/{SPEED_SCALING_TOPIC}", self._scaling_handler(arm),
                    SCALING_QOS) for arm in ARM_COMMAND_SLICES]
        for msg_type, topic, handler, qos in inputs:
            if self.control_loop == "thread":
                self._polled.append((PolledSubscription(self, msg_type, topic, qos), handler))
            else:
                self.create_subscription(msg_type, topic, handler, qos, raw=True)
        self.create_service(Trigger, "~/record_q_dance", self._record_q_dance)
        self.create_service(Trigger, "~/release_q_dance", self._release_q_dance)
        self.create_service(Trigger, "~/reset", self._reset)
        self.diag_pub = self.create_publisher(DiagnosticArray, "/diagnostics", 10)
        period = 1.0 / float(self.params["rate_hz"])
        if self.control_loop == "thread":
            self.loop = PeriodicThread(period, self.run_cycle, self._loop_failed,
                                       name=f"{self.get_name()} control",
                                       priority=int(self.params["thread_priority"]))
        else:
            # timer_callback: the executor inspects the callback's signature at every call.
            self.timer = self.create_timer(period, timer_callback(lambda: self.run_cycle()))
        self.diag_timer = self.create_timer(1.0, self.publish_diagnostics)

    def _contact_handler(self, link: str) -> Callable[[bytes], None]:
        """Serialized contact states of ``link`` → :meth:`on_contact_bytes` (looked up at each
        call: tests and benchmarks replace it on the instance)."""
        return lambda data: self.on_contact_bytes(link, data)

    def _scaling_handler(self, arm: str) -> Callable[[bytes], None]:
        """Serialized speed scaling of ``arm`` → :meth:`on_speed_scaling_bytes`."""
        return lambda data: self.on_speed_scaling_bytes(arm, data)

    # -- parameters -----------------------------------------------------------------------------
    def _config(self, values: dict[str, ParamValue]) -> Any:
        return config_from_values(values, self.links, self.arm_joints)

    def _on_params(self, values: dict[str, ParamValue]) -> None:
        config = self._config(values)  # raises ValueError naming the parameter
        timeouts = freshness_config(values)
        if self.controller is not None:
            with self.cycle_lock:
                self.controller.configure(config)
                self.freshness.config = timeouts
                self.torque_watch.config = torque_guard_config(values)
                self.skin_check.config = skin_check_config(values)

    # -- inputs ---------------------------------------------------------------------------------
    def now_s(self) -> float:
        """The node clock [s] (simulation time under ``use_sim_time``; see the module docstring)."""
        return self.clock_ns() * 1e-9

    @property
    def odom_time(self) -> float:
        """When the latest odometry arrived (node clock [s]; −∞: never; phri_sim's lock-step)."""
        return self.freshness.odom_time

    @property
    def arm_time(self) -> tuple[float, ...]:
        """When each arm joint's position last arrived (node clock [s]; −∞: never; phri_sim)."""
        return self.freshness.joint_time

    def _refuse(self, what: str, err: Exception) -> None:
        self.rejected_inputs += 1
        self.get_logger().warning(f"refused {what}: {err}", throttle_duration_sec=1.0)

    def on_contact_bytes(self, link: str, data: bytes) -> None:
        """A serialized contact state of ``link`` (the subscriptions' path)."""
        try:
            state = contact_from_cdr(data)
            if state is None:  # not phri's own layout: the reference decoder
                state = msg_to_contact(deserialize_message(data, PointCloud2))
        except ContactMessageError as err:
            self._refuse_contact(link, err)
            return
        self.take_contact(link, state)

    def on_contact(self, link: str, msg: PointCloud2) -> None:
        """A contact state message of ``link``: decoded, checked, kept for the next cycle."""
        try:
            state = msg_to_contact(msg)
        except ContactMessageError as err:
            self._refuse_contact(link, err)
            return
        self.take_contact(link, state)

    def take_contact(self, link: str, state: ContactState) -> None:
        """Check a decoded contact state of ``link`` and keep it (or refuse it)."""
        try:
            if state.link != link:
                raise InputError(f"frame_id {state.link!r} on the topic of {link!r}")
            check_contact_force(link, state.force.tolist(),
                                float(self.params["max_contact_force"]))
        except InputError as err:
            self._refuse_contact(link, err)
            return
        self.contacts[link] = state
        self.freshness.contact_arrived(link, self.now_s())

    def _refuse_contact(self, link: str, err: Exception) -> None:
        self._refuse(f"contact state of {link}", err)
        self.freshness.contact_refused(link)  # F9

    def on_joints_bytes(self, data: bytes) -> None:
        """A serialized joint state (the subscription's path)."""
        try:
            decoded = joint_state_arrays_from_cdr(data)
        except CdrError as err:
            self._refuse("joint state", err)
            self.freshness.joints_refused(set(self.arm_joints))  # F9: names unreadable
            return
        if decoded is None:  # big-endian: the reference deserializer
            self.on_joints(deserialize_message(data, JointState))
        else:
            self.take_joints(*decoded)

    def on_joints(self, msg: JointState) -> None:
        """A joint state message."""
        self.take_joints(msg.name, msg.position, msg.velocity, msg.effort)

    def take_joints(self, names: Sequence[str], position: Sequence[float],
                    velocity: Sequence[float] = (), effort: Sequence[float] = ()) -> None:
        """Check a joint state's names and positions [rad] and keep them (or refuse them); its
        velocities [rad/s] and efforts [N·m] go to the external-torque estimate."""
        try:
            positions = positions_by_name(names, position)
            check_joint_positions(positions, self.joint_limits,
                                  float(self.params["joint_limit_margin"]))
        except InputError as err:
            self._refuse("joint state", err)
            self.freshness.joints_refused(set(names) or set(self.arm_joints))  # F9
            return
        for i, name in enumerate(self.arm_joints):
            if name in positions:
                self.arm_q[i] = positions[name]
        self.freshness.joints_arrived(positions.keys(), self.now_s())
        self.torque_watch.estimator.joints(self.now_s(), names, position, velocity, effort)

    def on_odom_bytes(self, data: bytes) -> None:
        """Serialized odometry (the subscription's path)."""
        try:
            pose = odometry_pose_from_cdr(data)
            if pose is None:  # big-endian: the reference deserializer
                self.on_odom(deserialize_message(data, Odometry))
                return
            base = pose_to_base(pose)
        except (CdrError, InputError) as err:
            self._refuse("odometry", err)
            self.freshness.odom_refused()  # F9
            return
        self.take_base(base)

    def on_odom(self, msg: Odometry) -> None:
        """An odometry message."""
        try:
            base = odom_to_base(msg)
        except InputError as err:
            self._refuse("odometry", err)
            self.freshness.odom_refused()  # F9
            return
        self.take_base(base)

    def take_base(self, base: NDArray[np.float64]) -> None:
        """Check an odometry base pose q_b = [x, y, yaw] for a jump and keep it (or refuse it)."""
        try:
            previous, self._last_odom = self._last_odom, base.tolist()
            check_odometry_jump(previous, self._last_odom, float(self.params["max_odom_jump"]))
        except InputError as err:
            self._refuse("odometry", err)
            self.freshness.odom_refused()  # F9
            return
        self.base_q = base
        self.freshness.odom_arrived(self.now_s())
        self.torque_watch.estimator.base(self.now_s(), base)

    def on_speed_scaling_bytes(self, arm: str, data: bytes) -> None:
        """A serialized speed scaling of ``arm`` (std_msgs/Float64, percent); unreadable bytes
        are refused like a bad value."""
        try:
            percent = float(deserialize_message(data, Float64).data)
        except Exception as err:  # rclpy raises its own error types for bytes it cannot read
            self._refuse(f"speed scaling of {arm}", err)
            self.speed_scaling[arm] = 0.0
            return
        self.take_speed_scaling(arm, percent)

    def take_speed_scaling(self, arm: str, percent: float) -> None:
        """Keep ``arm``'s speed scaling [%] as a fraction; a refused value counts as 0 (zero
        command) until the next good one."""
        try:
            self.speed_scaling[arm] = speed_scaling_fraction(percent)
        except InputError as err:
            self._refuse(f"speed scaling of {arm}", err)
            self.speed_scaling[arm] = 0.0

    def _speed_scaling_refuses(self, now_ns: int) -> bool:
        """True while the slowest arm's speed scaling is below ``min_speed_scaling``
        (:class:`ScalingGate`): zero command, the tasks reset once, a warning at most once a
        second."""
        refuse, began, warning = self.scaling_gate.check(
            self.speed_scaling, float(self.params["min_speed_scaling"]), now_ns)
        if began and self.controller is not None:
            self.controller.reset()
        if warning:
            self.get_logger().warning(warning)
        return refuse

    # -- services -------------------------------------------------------------------------------
    def _record_q_dance(self, _req: Trigger.Request, res: Trigger.Response) -> Trigger.Response:
        with self.cycle_lock:
            return self._record_q_dance_locked(res)

    def _record_q_dance_locked(self, res: Trigger.Response) -> Trigger.Response:
        if not self.freshness.all_joints_received():
            res.success, res.message = False, "no joint state received for every arm joint"
            return res
        result = self.set_parameters([
            rclpy.parameter.Parameter("q_dance", value=[float(x) for x in self.arm_q]),
            rclpy.parameter.Parameter("q_dance_enabled", value=True),
        ])
        res.success = all(r.successful for r in result)
        res.message = "; ".join(r.reason for r in result if not r.successful) or (
            f"q_dance = {np.round(self.arm_q, 4).tolist()}"
        )
        return res

    def _release_q_dance(self, _req: Trigger.Request, res: Trigger.Response) -> Trigger.Response:
        with self.cycle_lock:
            result = self.set_parameters(
                [rclpy.parameter.Parameter("q_dance_enabled", value=False)])
            res.success = result[0].successful
            res.message = result[0].reason or "q_dance released"
        return res

    def _reset(self, _req: Trigger.Request, res: Trigger.Response) -> Trigger.Response:
        with self.cycle_lock:
            if self.controller is not None:
                self.controller.reset()
            cleared = self.safe_stop.clear()
            self.skin_check.reset()
        res.success, res.message = True, "interaction tasks reset"
        if cleared:
            res.message += f"; safe stop cleared ({', '.join(cleared)})"
            self.get_logger().warning(f"~/reset: {res.message}")
        return res

    def trip_safe_stop(self, kind: str, message: str) -> None:
        """A plausibility verdict (:mod:`~wholebody_controller.safe_stop`): exact zero from the
        next cycle on until ``~/reset``; logged ERROR and reported at once."""
        with self.cycle_lock:
            new = self.safe_stop.trip(kind, message)
        if new:
            self.get_logger().error(f"safe stop ({kind}): {message}; exact zero command until "
                                    "~/reset")
            self.publish_diagnostics()

    # -- control cycle --------------------------------------------------------------------------
    def publish_zero(self) -> None:
        """Zero base twist and zero arm velocities."""
        self.publish_command(np.zeros(15))

    def publish_command(self, command: NDArray[np.float64]) -> None:
        """The base twist (base frame) and both arms' joint velocities of ``command`` (15)."""
        values = command.tolist()
        left, right = self._arm_encoders
        self.cmd_pub.publish(twist_to_cdr(values[0], values[1], values[2]))
        self.left_pub.publish(left.encode(values[3:9]))
        self.right_pub.publish(right.encode(values[9:15]))

    def run_cycle(self) -> None:
        """One period: take the polled inputs (``control_loop: thread``), then :meth:`tick`."""
        with self.cycle_lock:
            for sub, handler in self._polled:
                for data in sub.take_all():
                    handler(data)
            self.tick()

    def _loop_failed(self, err: BaseException) -> None:
        """The control thread ended on an unexpected error: zero command, ERROR, stop."""
        self.fatal_error = err
        self.get_logger().fatal(f"control loop stopped by an unexpected error: {err!r}; "
                                "zero command, the process exits")
        try:
            self.publish_zero()
            self.publish_diagnostics()
        except Exception as exc:  # the context may be going down
            self.get_logger().error(f"could not publish the zero command: {exc}")

    def tick(self) -> None:
        """One control cycle on the latest inputs (called by :meth:`run_cycle`)."""
        assert self.controller is not None
        now_ns = self.clock_ns()
        verdict = self.freshness.check(now_ns * 1e-9)
        if verdict.reason is not None:
            if verdict.became_stale:
                self.get_logger().warning(f"{verdict.reason}: zero command",
                                          throttle_duration_sec=1.0)
                self.controller.reset()
            self.zero_cycles += 1
            self.publish_zero()
            return
        if self._speed_scaling_refuses(now_ns) or self._safe_stopped():
            self.zero_cycles += 1
            self.publish_zero()
            return
        q = np.concatenate([self.base_q, self.arm_q])
        try:
            result = self.controller.step(q, self.contacts)
        except (QPError, ValueError, np.linalg.LinAlgError) as err:
            # Reset what caused it (the tasks' admittance state): the next good cycle commands.
            self.controller.reset()
            self.qp_failures += 1
            self.zero_cycles += 1
            self.get_logger().error(f"control step failed: {err}; tasks reset, zero command",
                                    throttle_duration_sec=1.0)
            self.publish_zero()
            return
        if safety_changed(self.safety, result.tasks):  # diagnostics at once
            self.publish_diagnostics()
        command = self.torque_watch.apply(self.controller, now_ns * 1e-9, result.command, q,
                                          self.contacts)  # contacts no skin feels
        if self.torque_watch.changed:
            self.publish_diagnostics()
        kind, message = self.torque_watch.judge_skin(self.skin_check, self.contacts, now_ns * 1e-9)
        if kind:  # the skin against the joints: a verdict
            self.trip_safe_stop(kind, message)
            command = np.zeros(15)  # exact zero from this cycle on
        self.publish_command(scale_to_slowest(command, self.speed_scaling))
        frame = str(self.params["world_frame"])
        for i, task in enumerate(result.tasks):
            pub = self.state_pubs[task.link]
            if pub.get_subscription_count() > 0:  # debugging output: skip when nobody listens
                # tracking_errors is computed on first access: only when someone listens.
                error = result.tracking_errors[i]
                pub.publish(task_state_to_cdr(task, error, now_ns, frame))
        self.good_cycles += 1

    def _safe_stopped(self) -> bool:
        """While the safe stop is tripped: the tasks reset once, then the cycle sends zero."""
        stand, first = self.safe_stop.holds()
        if first and self.controller is not None:
            self.controller.reset()
        return stand

    def publish_diagnostics(self) -> None:
        """Per-link contact safety and the control loop on ``/diagnostics`` (1 Hz and on every
        safety change)."""
        assert self.controller is not None
        name = self.get_name()
        with self.cycle_lock:
            statuses = [safety_status(task, self.safety.get(task.link, Safety.OK), name)
                        for task in self.controller.tasks]
            loop = loop_status(name, self.control_loop, self.loop, self.fatal_error)
            statuses += robot_statuses(name, loop, self.safe_stop, self.torque_watch.report,
                                       self.skin_check, dict(self.speed_scaling),
                                       float(self.params["min_speed_scaling"]))
        msg = DiagnosticArray(status=statuses)
        msg.header.stamp = ns_to_stamp(self.clock_ns())
        self.diag_pub.publish(msg)

    def destroy_node(self) -> None:
        """Stop the control thread, send zero velocity, then tear down."""
        if self.loop is not None and not self.loop.stop(timeout=1.0):
            self.get_logger().error("the control thread did not stop within 1 s")
        for sub, _handler in self._polled:
            sub.destroy()
        self._polled = []
        try:
            self.publish_zero()
        except Exception as err:  # context may already be gone
            self.get_logger().warning(f"could not publish the final zero command: {err}")
        super().destroy_node()


def main(args: Sequence[str] | None = None) -> None:
    """Entry point ``wholebody_controller_node``; Ctrl-C / SIGTERM publish zero before exiting."""
    sys.exit(run_nodes(lambda: [WholeBodyControllerNode()], "wholebody_controller", args))
