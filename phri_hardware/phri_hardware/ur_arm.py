"""Decision logic of the UR arm bridge (pure: no rclpy, no ur_rtde).

The bridge between ``<arm>/forward_velocity_controller/commands`` and one UR16e decides, once per
control period, one of three things: send ``speedJ(qd)``, send ``speedStop``, or send nothing
(only kick the RTDE watchdog). :class:`ArmSupervisor` makes that decision from

* the robot's state (:class:`ArmState`: connection, robot mode, safety mode, protective and
  emergency stop, whether ur_rtde's control script runs), read through :class:`ArmInterface`;
* the newest command and the time it arrived.

Rules (design §8, docs/hardware.md "Safety"):

1. The arm moves only while connected, robot mode RUNNING, safety mode NORMAL (REDUCED only when
   allowed), no protective or emergency stop and the control script running. On leaving that
   state while moving: one ``speedStop``, then nothing (the robot's own safety system holds it).
2. After start-up and after every fault the bridge is *disarmed*: it starts moving only on a
   fresh command whose largest joint speed is at most ``rearm_velocity``, so a robot never jumps
   back to a speed commanded before a protective stop was released.
3. A command older than ``command_timeout`` (or none) → ``speedStop`` once if moving.
4. A command with NaN/Inf, the wrong length, or a joint speed above
   min(joint limit, ``velocity_cap``) is refused and replaced by zero velocity.

:class:`ArmInterface` is the module boundary to the robot: ``phri_hardware.rtde_arm`` implements
it with ur_rtde, ``phri_hardware.fake_arm`` with a simulated arm for tests and dry runs.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from enum import Enum, IntEnum
from typing import Protocol

from phri_common import paper
from phri_description.description import (
    UR16E_VELOCITY_LIMITS as _DESCRIPTION_UR16E_VELOCITY_LIMITS,
)
from phri_description.description import UR_JOINTS as _DESCRIPTION_UR_JOINTS

# The UR joint order and UR16e speed limits come from the one robot description (ur_robot_driver's
# joint order; design §5: 120°/s shoulder pan and lift, 180°/s the others).
UR_JOINTS = _DESCRIPTION_UR_JOINTS
UR16E_VELOCITY_LIMITS = _DESCRIPTION_UR16E_VELOCITY_LIMITS


class RobotMode(IntEnum):
    """UR robot mode (RTDE ``robot_mode``, ur_rtde ``getRobotMode``)."""

    NO_CONTROLLER = -1
    DISCONNECTED = 0
    CONFIRM_SAFETY = 1
    BOOTING = 2
    POWER_OFF = 3
    POWER_ON = 4
    IDLE = 5
    BACKDRIVE = 6
    RUNNING = 7
    UPDATING_FIRMWARE = 8


class SafetyMode(IntEnum):
    """UR safety mode (RTDE ``safety_mode``, ur_rtde ``getSafetyMode``)."""

    NORMAL = 1
    REDUCED = 2
    PROTECTIVE_STOP = 3
    RECOVERY = 4
    SAFEGUARD_STOP = 5
    SYSTEM_EMERGENCY_STOP = 6
    ROBOT_EMERGENCY_STOP = 7
    VIOLATION = 8
    FAULT = 9
    VALIDATE_JOINT_ID = 10
    UNDEFINED_SAFETY_MODE = 11
    AUTOMATIC_MODE_SAFEGUARD_STOP = 12
    SYSTEM_THREE_POSITION_ENABLING_STOP = 13


def mode_name(kind: type[IntEnum], value: int) -> str:
    """``RUNNING`` for a known value, ``UNKNOWN(42)`` otherwise."""
    try:
        return kind(value).name
    except ValueError:
        return f"UNKNOWN({value})"


@dataclass(frozen=True)
class ArmState:
    """One reading of the robot (RTDE receive).

    Attributes:
        q: joint positions [rad], UR order.
        qd: joint velocities [rad/s], UR order.
        robot_mode: :class:`RobotMode` value.
        safety_mode: :class:`SafetyMode` value.
        protective_stopped: the robot is in a protective stop.
        emergency_stopped: an emergency stop is engaged.
        program_running: ur_rtde's control script runs on the controller (speedJ needs it).
        connected: both RTDE connections are up.
        speed_scaling: the fraction of every commanded speed the robot executes, 0–1: the
            teach pendant's speed slider (RTDE ``target_speed_fraction``) times the trajectory
            limiter's scaling (``speed_scaling``), ramped up from 0 after a pause (ur_rtde
            ``getSpeedScalingCombined``, the value ur_robot_driver publishes).
        effort: the torque each joint's drive applies [N·m], gravity included
            (:mod:`phri_hardware.rtde_arm`: from RTDE's currents and target moments); nan where
            not known yet.
    """

    q: tuple[float, ...]
    qd: tuple[float, ...]
    robot_mode: int
    safety_mode: int
    protective_stopped: bool = False
    emergency_stopped: bool = False
    program_running: bool = True
    connected: bool = True
    speed_scaling: float = 1.0
    effort: tuple[float, ...] = (math.nan,) * 6


DISCONNECTED_STATE = ArmState(
    q=(math.nan,) * 6, qd=(math.nan,) * 6, robot_mode=RobotMode.DISCONNECTED,
    safety_mode=SafetyMode.UNDEFINED_SAFETY_MODE, program_running=False, connected=False,
    speed_scaling=0.0,
)


class ArmInterface(Protocol):
    """What the bridge needs from one arm (ur_rtde is wrapped behind it in ``rtde_arm``).

    Every call may block (ur_rtde talks TCP and can hold the GIL): the bridge calls them only in
    its worker process, never on the ROS executor.
    """

    def connect(self) -> None:
        """Open the connection; raise ``ConnectionError`` (or any exception) on failure."""

    def read_state(self) -> ArmState:
        """Current state; ``connected=False`` when the connection is lost."""

    def speed_j(self, qd: Sequence[float], acceleration: float, time: float) -> bool:
        """ur_rtde ``speedJ(qd [rad/s], acceleration [rad/s²], time [s])``."""

    def speed_stop(self, deceleration: float) -> bool:
        """ur_rtde ``speedStop(a [rad/s²])``: decelerate to zero and leave speed mode."""

    def set_watchdog(self, min_frequency: float) -> bool:
        """ur_rtde ``setWatchdog(min_frequency [Hz])``: the control script stops the robot when
        no input update arrives at this rate."""

    def kick_watchdog(self) -> bool:
        """ur_rtde ``kickWatchdog()``."""

    def restart_program(self) -> bool:
        """ur_rtde ``reuploadScript()`` after a protective stop ended the control script."""

    def disconnect(self) -> None:
        """Close the connection (idempotent)."""


@dataclass(frozen=True)
class BridgeConfig:
    """Parameters of the decision logic (validated ranges: ``ur_arm_bridge_node.PARAMS``).

    Attributes:
        rate_hz: speedJ rate [Hz] (the controller rate; the UR16e's RTDE runs at 500 Hz).
        command_timeout: a command older than this is stale [s].
        acceleration: speedJ joint acceleration [rad/s²].
        stop_deceleration: speedStop deceleration [rad/s²].
        velocity_cap: largest accepted joint speed [rad/s], below the UR16e's own limits.
        joint_velocity_limits: per-joint limits [rad/s] (UR16e, design §5).
        rearm_velocity: largest joint speed of the command that arms the bridge [rad/s].
        allow_reduced_safety: also move in the REDUCED safety mode.
    """

    rate_hz: float = paper.CONTROL_RATE_HZ
    command_timeout: float = 0.1
    acceleration: float = 2.0
    stop_deceleration: float = 4.0
    velocity_cap: float = 0.5
    joint_velocity_limits: tuple[float, ...] = UR16E_VELOCITY_LIMITS
    rearm_velocity: float = 0.01
    allow_reduced_safety: bool = False

    def __post_init__(self) -> None:
        if len(self.joint_velocity_limits) != len(UR_JOINTS):
            raise ValueError(f"joint_velocity_limits needs {len(UR_JOINTS)} entries")
        named = [(name, getattr(self, name)) for name in (
            "rate_hz", "command_timeout", "acceleration", "stop_deceleration", "velocity_cap",
            "rearm_velocity")]
        named += [(f"joint_velocity_limits[{j}]", v)
                  for j, v in enumerate(self.joint_velocity_limits)]
        for name, value in named:
            if not (math.isfinite(value) and value >= 0.0) or (name == "rate_hz" and value <= 0):
                raise ValueError(
                    f"bridge setting {name} refused value {value!r}: allowed "
                    f"{'(0' if name == 'rate_hz' else '[0'}, inf), finite"
                )

    @property
    def period(self) -> float:
        """Control period [s]."""
        return 1.0 / self.rate_hz

    @property
    def effective_limits(self) -> tuple[float, ...]:
        """Per-joint accepted speed: min(joint limit, velocity_cap) [rad/s]."""
        return tuple(min(lim, self.velocity_cap) for lim in self.joint_velocity_limits)


class CommandError(ValueError):
    """A velocity command is refused; the message says why."""


def validate_command(values: Sequence[float], limits: Sequence[float]) -> tuple[float, ...]:
    """Return the command as a tuple if every joint speed is finite and within its limit.

    Raises:
        CommandError: wrong length, NaN/Inf, or |qd_j| > limits[j] (message names the joint).
    """
    if len(values) != len(limits):
        raise CommandError(f"expected {len(limits)} joint velocities, got {len(values)}")
    qd = tuple(float(v) for v in values)
    for j, (v, lim) in enumerate(zip(qd, limits, strict=True)):
        name = UR_JOINTS[j] if j < len(UR_JOINTS) else str(j)
        if not math.isfinite(v):
            raise CommandError(f"{name}: {v} is not finite")
        if abs(v) > lim:
            raise CommandError(f"{name}: |{v:.4g}| rad/s exceeds the limit {lim:.4g} rad/s")
    return qd


def robot_fault(
    state: ArmState, allow_reduced_safety: bool = False, need_program: bool = True
) -> str | None:
    """Why the robot must not be commanded now, or ``None`` when it may move.

    ``need_program=False`` skips the control-script check (monitor mode runs no script).
    """
    if not state.connected:
        return "not connected"
    if state.emergency_stopped:
        return "emergency stop"
    if state.protective_stopped or state.safety_mode == SafetyMode.PROTECTIVE_STOP:
        return "protective stop"
    allowed = {SafetyMode.NORMAL} | ({SafetyMode.REDUCED} if allow_reduced_safety else set())
    if state.safety_mode not in allowed:
        return f"safety mode {mode_name(SafetyMode, state.safety_mode)}"
    if state.robot_mode != RobotMode.RUNNING:
        return f"robot mode {mode_name(RobotMode, state.robot_mode)}"
    if need_program and not state.program_running:
        return "control script not running"
    return None


class Action(Enum):
    """What to send to the arm this period."""

    SPEED_J = "speedJ"
    SPEED_STOP = "speedStop"
    NONE = "none"


@dataclass(frozen=True)
class Decision:
    """One period's decision: the action, the joint speeds for SPEED_J [rad/s], and why."""

    action: Action
    qd: tuple[float, ...] = (0.0,) * 6
    reason: str = ""


@dataclass
class SupervisorCounters:
    """Counts since start-up (reported on diagnostics)."""

    commands: int = 0
    refused: int = 0
    speed_j: int = 0
    speed_stop: int = 0
    stale_stops: int = 0
    fault_stops: int = 0
    last_refusal: str = ""


@dataclass
class _Command:
    qd: tuple[float, ...]
    stamp: float


@dataclass
class ArmSupervisor:
    """The bridge's decisions (module docstring lists the rules). Times are monotonic [s]."""

    config: BridgeConfig = field(default_factory=BridgeConfig)
    counters: SupervisorCounters = field(default_factory=SupervisorCounters)
    moving: bool = False
    armed: bool = False
    _command: _Command | None = None
    hold_reason: str = "no command yet"

    def command(self, values: Sequence[float], stamp: float) -> str | None:
        """Store a command received at ``stamp``; a refused one becomes zero velocity.

        Returns the refusal message, or ``None`` when accepted.
        """
        self.counters.commands += 1
        try:
            qd = validate_command(values, self.config.effective_limits)
        except CommandError as err:
            self.counters.refused += 1
            self.counters.last_refusal = str(err)
            self._command = _Command((0.0,) * len(UR_JOINTS), stamp)
            return str(err)
        self._command = _Command(qd, stamp)
        return None

    def _stop_if_moving(self, reason: str, fault: bool) -> Decision:
        self.hold_reason = reason
        if not self.moving:
            return Decision(Action.NONE, reason=reason)
        self.moving = False
        self.counters.speed_stop += 1
        if fault:
            self.counters.fault_stops += 1
        else:
            self.counters.stale_stops += 1
        return Decision(Action.SPEED_STOP, reason=reason)

    def step(self, now: float, state: ArmState) -> Decision:
        """Decide this period's action from the robot state and the newest command."""
        fault = robot_fault(state, self.config.allow_reduced_safety)
        if fault is not None:
            self.armed = False
            return self._stop_if_moving(fault, fault=True)
        cmd = self._command
        if cmd is None:
            return self._stop_if_moving("no command yet", fault=False)
        if now - cmd.stamp > self.config.command_timeout:
            return self._stop_if_moving("command stale", fault=False)
        if not self.armed:
            if max(abs(v) for v in cmd.qd) > self.config.rearm_velocity:
                return self._stop_if_moving(
                    f"disarmed: waiting for a command below {self.config.rearm_velocity} rad/s",
                    fault=False,
                )
            self.armed = True
        self.moving = True
        self.hold_reason = ""
        self.counters.speed_j += 1
        return Decision(Action.SPEED_J, qd=cmd.qd, reason="command")

    def shutdown(self) -> Decision:
        """Final decision: speedStop unless the arm is known to be still (then nothing).

        Always stops when the bridge ever moved the arm; a stop on a still arm is harmless, so the
        decision errs towards stopping.
        """
        self.armed = False
        self._command = None
        self.moving = False
        self.counters.speed_stop += 1
        return Decision(Action.SPEED_STOP, reason="shutdown")


def apply_decision(arm: ArmInterface, decision: Decision, config: BridgeConfig) -> bool:
    """Send ``decision`` to ``arm``; kick the watchdog when nothing else is sent.

    Any command keeps ur_rtde's watchdog alive (each writes the command register); a period without
    one kicks it explicitly, so the watchdog fires only when the worker itself stops.
    Returns the interface's success flag.
    """
    if decision.action is Action.SPEED_J:
        return arm.speed_j(list(decision.qd), config.acceleration, config.period)
    if decision.action is Action.SPEED_STOP:
        return arm.speed_stop(config.stop_deceleration)
    return arm.kick_watchdog()


__all__ = [
    "DISCONNECTED_STATE",
    "UR16E_VELOCITY_LIMITS",
    "UR_JOINTS",
    "Action",
    "ArmInterface",
    "ArmState",
    "ArmSupervisor",
    "BridgeConfig",
    "CommandError",
    "Decision",
    "RobotMode",
    "SafetyMode",
    "SupervisorCounters",
    "apply_decision",
    "mode_name",
    "robot_fault",
    "validate_command",
]
