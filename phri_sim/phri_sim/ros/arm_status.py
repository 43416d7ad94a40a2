"""The simulated arms' state on ``/diagnostics``, as phri_hardware's UR arm bridge reports it.

On the robot each arm's ``ur_arm_bridge`` (namespace ``/left`` or ``/right``) publishes one
``DiagnosticStatus`` named ``/<arm>/ur_arm_bridge: UR arm`` with the robot and safety modes it
reads over RTDE (docs/hardware.md, "Diagnostics"): ERROR ``protective stop`` while the arm is
protective-stopped, WARN ``disarmed: waiting for a command below … rad/s`` after the stop is
unlocked until a command near zero arrives, OK ``moving on command`` otherwise. The simulator's
bridge publishes the same statuses for its arms (:mod:`phri_sim.world.protective_stop`), with
the same names and keys, so whatever watches the real bridges watches the simulated arms; the
keys ``protective_stops``, ``last_stop_joint``, ``last_stop_torque_Nm`` and
``last_stop_allowed_Nm`` tell what tripped the last stop.
"""

from __future__ import annotations

import math

from diagnostic_msgs.msg import DiagnosticStatus, KeyValue

from phri_sim.world.protective_stop import StopPhase, StopStatus


def arm_status_name(side: str) -> str:
    """``/left/ur_arm_bridge: UR arm``: the real bridge's status name for arm ``side``."""
    return f"/{side}/ur_arm_bridge: UR arm"


def arm_status(side: str, status: StopStatus, rearm_velocity: float) -> DiagnosticStatus:
    """The arm bridge's status of simulated arm ``side`` (module docstring)."""
    stopped = status.protective_stopped
    disarmed = status.phase == StopPhase.DISARMED.value
    if stopped:
        level, message = DiagnosticStatus.ERROR, "protective stop"
    elif disarmed:
        level = DiagnosticStatus.WARN
        message = f"disarmed: waiting for a command below {rearm_velocity} rad/s"
    else:
        level, message = DiagnosticStatus.OK, "moving on command"
    values = {
        "mode": "control", "link_phase": "running", "robot_mode": "RUNNING",
        "safety_mode": status.safety_mode, "protective_stopped": str(stopped),
        "emergency_stopped": "False", "program_running": str(not stopped),
        "speed_scaling": "100 %", "armed": str(not (stopped or disarmed)),
        "hold_reason": message if level != DiagnosticStatus.OK else "",
        "protective_stops": str(status.stops), "last_stop_joint": status.last_joint,
        "last_stop_torque_Nm": f"{status.last_torque:.1f}",
        "last_stop_allowed_Nm": f"{status.last_allowed:.1f}",
        "last_stop_time_s": "" if math.isnan(status.stopped_at) else f"{status.stopped_at:.3f}",
    }
    return DiagnosticStatus(level=level, name=arm_status_name(side),
                            hardware_id=f"phri_sim:{side}", message=message,
                            values=[KeyValue(key=k, value=v) for k, v in values.items()])


__all__ = ["arm_status", "arm_status_name"]
