"""Message ↔ numpy conversions of the controller node (pure: message types, no rclpy).

Commands:
  * ``/cmd_vel`` (``geometry_msgs/Twist``): base twist in the base frame, ``linear.x/y`` [m/s],
    ``angular.z`` [rad/s]; everything else 0.
  * ``<arm>/forward_velocity_controller/commands`` (``std_msgs/Float64MultiArray``): 6 joint
    velocities [rad/s] in the order shoulder_pan, shoulder_lift, elbow, wrist_1, wrist_2, wrist_3
    (ur_robot_driver's order), one ``dim`` labelled with the joint names joined by commas.

Speed scaling (``<arm>/speed_scaling_state_broadcaster/speed_scaling``, ``std_msgs/Float64``,
ur_robot_driver's topic, published by it and by phri_hardware's UR bridge): the fraction of every
commanded joint speed the UR executes, in percent 0–100 (:func:`speed_scaling_fraction`).

Task state (``~/state/<link>``, ``sensor_msgs/PointCloud2``, one point, self-describing fields —
see :data:`TASK_STATE_FIELDS`): header.frame_id is the world frame; every vector is in it except
``center_link_*`` (ᶦp_η, link frame).
"""

from __future__ import annotations

import math
import struct
from collections.abc import Sequence

import numpy as np
from diagnostic_msgs.msg import DiagnosticStatus, KeyValue
from geometry_msgs.msg import Twist
from nav_msgs.msg import Odometry
from numpy.typing import NDArray
from sensor_msgs.msg import JointState, PointCloud2
from std_msgs.msg import Float64MultiArray, Header, MultiArrayDimension

from phri_common.cdr import stamped_header_cdr
from phri_common.cloud import cloud_records, point_fields, record_dtype
from phri_common.contact_cdr import Template, cloud_header, layout_template, matches
from phri_common.periodic import PeriodicThread
from phri_common.planar import yaw_from_quaternion
from phri_common.stamps import ns_to_stamp
from wholebody_controller.contact_safety import Safety
from wholebody_controller.contact_task import (
    CONTROL,
    DEFLECTION,
    DEFLECTION_VELOCITY,
    POINT,
    TRACK_FORCE,
    WRENCH,
    TaskOutput,
)
from wholebody_controller.input_checks import InputError
from wholebody_controller.safe_stop import SafeStop
from wholebody_controller.skin_torque_check import SkinTorqueCheck
from wholebody_controller.tasks import ContactTask
from wholebody_controller.torque_guard import GuardReport, GuardState

Array = NDArray[np.float64]

_LIN = ("x", "y", "z")
_TWIST = ("vx", "vy", "vz", "wx", "wy", "wz")
_POSE6 = ("x", "y", "z", "rx", "ry", "rz")
_WRENCH = ("fx", "fy", "fz", "tx", "ty", "tz")
_VECTOR_FIELDS: tuple[tuple[str, tuple[str, ...]], ...] = (
    ("deflection", _POSE6),
    ("deflection_velocity", _TWIST),
    ("wrench", _WRENCH),
    ("track_force", _LIN),
    ("control_velocity", _TWIST),
    ("tracking_error", _TWIST),
    ("center_link", _LIN),
)
_STATE_DTYPE = record_dtype(
    [("psi", "f8"), ("psi_raw", "f8")]
    + [(f"{name}_{axis}", "f8") for name, axes in _VECTOR_FIELDS for axis in axes]
    + [("phase", "u1"), ("in_contact", "u1")]
)
#: Field names of the task-state record, in order.
TASK_STATE_FIELDS: tuple[str, ...] = tuple(_STATE_DTYPE.names or ())
# The node publishes one record per link per cycle (500 Hz): pack with struct in the dtype's
# packed layout and reuse the field list, instead of a numpy record filled field by field.
_STATE_FIELDS = point_fields(_STATE_DTYPE)
_STATE_PACK = struct.Struct(f"<{len(TASK_STATE_FIELDS) - 2}dBB")
assert _STATE_PACK.size == _STATE_DTYPE.itemsize
_STATE_BYTES, _STATE_MASK = layout_template(_STATE_FIELDS, _STATE_PACK.size)
_STATE_TEMPLATE = Template(_STATE_BYTES, _STATE_MASK)
"""The task state's CDR bytes from height to the data length (:func:`task_state_from_cdr`)."""


def command_to_twist(command: Array) -> Twist:
    """Base part of the command ``[v_x, v_y, ω_z, …]`` → ``Twist`` (base frame)."""
    twist = Twist()
    twist.linear.x = float(command[0])
    twist.linear.y = float(command[1])
    twist.angular.z = float(command[2])
    return twist


def arm_command(velocities: Array, joints: Sequence[str]) -> Float64MultiArray:
    """Six joint velocities [rad/s] → ``Float64MultiArray`` labelled with the joint order."""
    msg = Float64MultiArray()
    msg.layout.dim = [
        MultiArrayDimension(label=",".join(joints), size=len(joints), stride=len(joints))
    ]
    msg.data = [float(v) for v in velocities]
    return msg


def odom_to_base(msg: Odometry) -> Array:
    """``nav_msgs/Odometry`` → q_b = [x, y, yaw] (world/odom frame) [m, m, rad].

    Raises:
        InputError: non-finite pose or a quaternion far from unit length.
    """
    p = msg.pose.pose.position
    o = msg.pose.pose.orientation
    return pose_to_base((p.x, p.y, p.z, o.x, o.y, o.z, o.w))


def pose_to_base(pose: Sequence[float]) -> Array:
    """An odometry pose ``(x, y, z, qx, qy, qz, qw)`` → q_b = [x, y, yaw] [m, m, rad]
    (z is not used; :func:`phri_common.cdr.odometry_pose_from_cdr` gives this tuple).

    Raises:
        InputError: non-finite x, y or quaternion, or a quaternion far from unit length.
    """
    x, y, _z, qx, qy, qz, qw = pose
    values = (x, y, qx, qy, qz, qw)
    if not all(math.isfinite(v) for v in values):
        raise InputError(f"odometry holds non-finite values: {list(values)}")
    norm = math.sqrt(qx**2 + qy**2 + qz**2 + qw**2)
    if not 0.5 < norm < 1.5:
        raise InputError(f"odometry quaternion has norm {norm:.3g}")
    return np.array([x, y, yaw_from_quaternion(qw, qx, qy, qz)])


def joint_positions(msg: JointState) -> dict[str, float]:
    """``sensor_msgs/JointState`` → positions by joint name [rad] (see :func:`positions_by_name`).

    Raises:
        InputError: names and positions differ in length, or a position is not finite.
    """
    return positions_by_name(msg.name, msg.position)


def positions_by_name(names: Sequence[str], positions: Sequence[float]) -> dict[str, float]:
    """A joint state's ``name`` and ``position`` → positions by joint name [rad].

    Raises:
        InputError: names and positions differ in length, or a position is not finite.
    """
    if len(names) != len(positions):
        raise InputError(f"joint state has {len(names)} names but {len(positions)} positions")
    values = [float(v) for v in positions]
    if not all(math.isfinite(v) for v in values):
        bad = [n for n, v in zip(names, values, strict=True) if not math.isfinite(v)]
        raise InputError(f"joint state holds non-finite positions for {bad}")
    return dict(zip(names, values, strict=True))


def _task_state_data(task: TaskOutput, tracking_error: Array) -> bytes:
    """The record of :data:`TASK_STATE_FIELDS`: ψ, ψ_raw, deflection, deflection_velocity,
    wrench, track_force, control_velocity, tracking_error, center_link (the output's floats),
    phase, in_contact."""
    v = task.values
    return _STATE_PACK.pack(
        float(task.psi),
        float(task.psi_raw),
        *v[DEFLECTION],
        *v[DEFLECTION_VELOCITY],
        *v[WRENCH],
        *v[TRACK_FORCE],
        *v[CONTROL],
        *np.asarray(tracking_error, dtype=np.float64).tolist(),
        *v[POINT],
        int(task.phase),
        1 if task.in_contact else 0,
    )


def task_state_to_msg(
    task: TaskOutput, tracking_error: Array, stamp_ns: int, frame_id: str
) -> PointCloud2:
    """One link's controller state as a one-point PointCloud2 (fields :data:`TASK_STATE_FIELDS`)."""
    return PointCloud2(
        header=Header(stamp=ns_to_stamp(stamp_ns), frame_id=frame_id),
        height=1,
        width=1,
        fields=_STATE_FIELDS,
        is_bigendian=False,
        point_step=_STATE_DTYPE.itemsize,
        row_step=_STATE_DTYPE.itemsize,
        data=_task_state_data(task, tracking_error),
        is_dense=True,
    )


def task_state_to_cdr(task: TaskOutput, tracking_error: Array, stamp_ns: int,
                      frame_id: str) -> bytes:
    """:func:`task_state_to_msg` serialized, for ``Publisher.publish``: written from the layout's
    fixed bytes, without the 40 ``PointField`` objects rclpy would convert on every publish.

    Raises:
        ValueError: ``stamp_ns`` outside what a header holds, a NUL in ``frame_id``.
    """
    head = stamped_header_cdr(stamp_ns, frame_id, 4)
    return bytes(head) + _STATE_BYTES + _task_state_data(task, tracking_error) + b"\x01"


def task_state_from_cdr(data: bytes) -> dict[str, float] | None:
    """:func:`msg_to_task_state` of a serialized PointCloud2 in the layout
    :func:`task_state_to_msg` writes, read from the bytes (no rclpy message objects, whose 40
    ``PointField`` s cost far more than the record); ``None`` for any other layout, which the
    caller deserializes and decodes with :func:`msg_to_task_state`, the reference."""
    header = cloud_header(data)
    if header is None:
        return None
    start = header[2]
    end = start + _STATE_TEMPLATE.size
    if len(data) < end + _STATE_PACK.size or not matches(data, start, _STATE_TEMPLATE):
        return None
    values = _STATE_PACK.unpack_from(data, end)
    return {name: float(value) for name, value in zip(TASK_STATE_FIELDS, values, strict=True)}


def msg_to_task_state(msg: PointCloud2) -> dict[str, float]:
    """Decode a task-state PointCloud2 into ``{field: value}`` (for plots and tests)."""
    records = cloud_records(msg)
    if records.shape[0] != 1:
        raise InputError(f"task state must hold 1 point, got {records.shape[0]}")
    names = records.dtype.names or ()
    missing = [f for f in TASK_STATE_FIELDS if f not in names]
    if missing:
        raise InputError(f"task state lacks fields {missing}")
    return {name: float(records[0][name]) for name in TASK_STATE_FIELDS}


SPEED_SCALING_TOPIC = "speed_scaling_state_broadcaster/speed_scaling"
"""ur_robot_driver's speed scaling topic, below each arm's namespace (``left/…``)."""


def speed_scaling_fraction(percent: float) -> float:
    """A speed scaling message's value [%] → the executed fraction of commanded speed [0, 1].

    ur_robot_driver's speed_scaling_state_broadcaster publishes the robot's fraction times 100
    (ur_controllers/src/speed_scaling_state_broadcaster.cpp, every branch from humble to main).

    Raises:
        InputError: not finite or outside 0–100 % (names the value and the range).
    """
    value = float(percent)
    if not (math.isfinite(value) and 0.0 <= value <= 100.0):
        raise InputError(f"speed scaling {value!r} %: allowed 0–100 % (ur_robot_driver's "
                         "percent; a fraction 0–1 reads as at most 1 %)")
    return value / 100.0


def speed_scaling_status(node_name: str, scaling: dict[str, float], minimum: float
                         ) -> DiagnosticStatus:
    """The UR speed scaling as a diagnostic status: WARN while the smallest arm's scaling is
    below ``minimum`` (zero command), OK otherwise; values: each arm's scaling [%]."""
    smallest = min(scaling.values(), default=1.0)
    level, message = DiagnosticStatus.OK, "commands scaled to the arms' speed scaling"
    if not scaling:
        message = "no speed scaling received: commands unscaled"
    elif smallest < minimum:
        level = DiagnosticStatus.WARN
        message = (f"speed scaling {100 * smallest:.0f} % below min_speed_scaling "
                   f"{100 * minimum:.0f} %: zero command")
    values = {f"{arm}_speed_scaling": f"{100 * v:.0f} %" for arm, v in sorted(scaling.items())}
    values["min_speed_scaling"] = f"{100 * minimum:.0f} %"
    return DiagnosticStatus(
        level=level, name=f"{node_name}: speed scaling", message=message,
        hardware_id=node_name, values=[KeyValue(key=k, value=v) for k, v in values.items()])


def safe_stop_status(node_name: str, stop: SafeStop) -> DiagnosticStatus:
    """The safe stop (:mod:`~wholebody_controller.safe_stop`) as a diagnostic status: ERROR
    with the reasons while tripped (exact zero command until ``~/reset``), OK otherwise."""
    level, message = DiagnosticStatus.OK, "no plausibility verdict"
    if stop.active:
        level = DiagnosticStatus.ERROR
        message = f"safe stop, exact zero command until ~/reset: {stop.summary()}"
    return DiagnosticStatus(
        level=level, name=f"{node_name}: safe stop", message=message, hardware_id=node_name,
        values=[KeyValue(key="trips", value=str(stop.trips)),
                KeyValue(key="reasons", value=", ".join(stop.reasons) or "-")])


def safety_status(task: ContactTask, safety: Safety, node_name: str) -> DiagnosticStatus:
    """One link's contact safety as a diagnostic status: ERROR while yielding at the force limit
    or once the transient limit was exceeded, WARN after a contact loss stopped the desired
    force, OK otherwise; values: the state, the peak force and both limits [N]."""
    level, message = DiagnosticStatus.OK, "ok"
    if safety is Safety.FADING:
        message = "contact force above the fade start: approach and desired force fading"
    elif safety is Safety.CONTACT_LOST:
        level, message = DiagnosticStatus.WARN, "contact lost: desired force stopped"
    if safety is Safety.YIELDING:
        level, message = DiagnosticStatus.ERROR, "contact force at its limit: yielding"
    if task.transient_exceeded:
        level = DiagnosticStatus.ERROR
        message = f"transient force limit exceeded ({task.peak_force:.1f} N); {message}"
    values = {"state": safety.name, "peak_force_N": f"{task.peak_force:.3f}",
              "force_limit_N": f"{task.force_limit:g}",
              "transient_force_limit_N": f"{task.transient_force_limit:g}"}
    return DiagnosticStatus(
        level=level, name=f"{node_name}: contact safety {task.link}", message=message,
        hardware_id=task.link, values=[KeyValue(key=k, value=v) for k, v in values.items()])


def unsensed_status(node_name: str, report: GuardReport) -> DiagnosticStatus:
    """The guard against contacts no skin feels (:mod:`~wholebody_controller.torque_guard`) as a
    diagnostic status: ERROR while it stops the robot, WARN while slowing or while an arm joint
    reports no effort (unguarded), OK otherwise; values: the state, the worst joint's
    unexplained torque and limit [N·m], the ratio, stops, and τ_ext and the skin's share per
    joint [N·m]."""
    level, message = DiagnosticStatus.OK, "no unsensed contact"
    if not report.sensed:
        level, message = DiagnosticStatus.WARN, "no joint efforts: unsensed contacts unguarded"
    if report.state is GuardState.SLOWING:
        level = DiagnosticStatus.WARN
        message = f"unsensed contact at {report.joint}: slowing (×{report.scale:.2f})"
    elif report.state is GuardState.STOPPED:
        level = DiagnosticStatus.ERROR
        message = f"unsensed contact at {report.joint}: stopped, backing off"
    values = {"state": report.state.name, "joint": report.joint,
              "unexplained_torque_Nm": f"{report.torque:.2f}", "limit_Nm": f"{report.limit:g}",
              "ratio": f"{report.ratio:.3f}", "peak_ratio": f"{report.peak_ratio:.3f}",
              "stops": str(report.stops), "slowed_cycles": str(report.slowed),
              "external_torque_Nm": " ".join(f"{v:.2f}" for v in report.external),
              "skin_torque_Nm": " ".join(f"{v:.2f}" for v in report.skin)}
    return DiagnosticStatus(
        level=level, name=f"{node_name}: unsensed contact", message=message,
        hardware_id=node_name, values=[KeyValue(key=k, value=v) for k, v in values.items()])


def skin_check_status(node_name: str, check: SkinTorqueCheck) -> DiagnosticStatus:
    """The skin against the joints (:mod:`~wholebody_controller.skin_torque_check`) as a
    diagnostic status: WARN while switched off, OK otherwise (a verdict is the safe stop's
    ERROR); values: the last judged gain ρ and fit residual."""
    level, message = DiagnosticStatus.OK, "skin checked against the joints' torques"
    if not check.config.enabled:
        level, message = DiagnosticStatus.WARN, "skin_torque_check off: skin not checked"
    values = {"gain_ratio": f"{check.ratio:.3f}", "fit_residual": f"{check.residual:.3f}"}
    return DiagnosticStatus(
        level=level, name=f"{node_name}: skin against joints", message=message,
        hardware_id=node_name, values=[KeyValue(key=k, value=v) for k, v in values.items()])


def robot_statuses(node_name: str, loop: DiagnosticStatus, safe_stop: SafeStop,
                   report: GuardReport, check: SkinTorqueCheck, scaling: dict[str, float],
                   min_scaling: float) -> list[DiagnosticStatus]:
    """The node's statuses beside the links': the ``loop``'s (:func:`loop_status`), speed
    scaling, safe stop, unsensed contacts, the skin against the joints."""
    return [loop, speed_scaling_status(node_name, scaling, min_scaling),
            safe_stop_status(node_name, safe_stop), unsensed_status(node_name, report),
            skin_check_status(node_name, check)]


def loop_status(node_name: str, mode: str, loop: PeriodicThread | None,
                error: BaseException | None) -> DiagnosticStatus:
    """The control loop as a diagnostic status: ERROR once the control thread stopped on an
    unexpected error, OK otherwise; values: the mode, cycles run and deadlines overrun."""
    level, message = DiagnosticStatus.OK, f"running ({mode})"
    if error is not None:
        level, message = DiagnosticStatus.ERROR, f"control loop stopped: {error!r}"
    values = {"control_loop": mode}
    if loop is not None:
        values.update(cycles=str(loop.cycles), overruns=str(loop.overruns))
    return DiagnosticStatus(
        level=level, name=f"{node_name}: control loop", message=message, hardware_id=node_name,
        values=[KeyValue(key=k, value=v) for k, v in values.items()])
