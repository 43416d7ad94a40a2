"""The UR16e's own protective stop, as the arm's controller does it (pure, no rclpy).

A real UR watches every joint's torque: the torque its drive applies (measured through the motor
current) against the torque its model says the commanded motion needs. A deviation beyond what
the configured force limit allows is a collision, and the robot **protective-stops**: a stop of
category 2 — it decelerates along its path with the drives powered and holds where it stopped
(IEC 60204-1; UR e-Series hardware manual, "Stop categories"). The safety system computes the
torque each joint may apply "so that the TCP/tool positions and elbow joint stay within the force
limits" (UR manual, "Force limits"); the **Default** safety preset limits the tool and the elbow to
150 N (documented tolerance 25 N). It acts on every joint, whatever link the contact is on: with
skin or without.

The model (:class:`ProtectiveStop`, once per physics step, before the servo set points are
written):

* **Deviation** of arm joint j: τ_dev,j = τ_drive,j − τ_model,j, where τ_drive is what the drive
  applies — the velocity servo's torque (:func:`servo_forces`) plus the gravity torque the
  model's gravity compensation carries (``qfrc_passive`` holds both that and any joint
  damping) — and τ_model the inverse
  dynamics of the arm on a **fixed** base (MuJoCo's ``mj_rne`` with the base at rest, the arm's
  own joint velocities and accelerations, the rotor inertia ``armature · q̈``): the UR's model
  knows nothing of the mobile base it stands on, so the base's accelerations show as deviation,
  as on the real robot. With the base still τ_dev = −(the contact forces' joint torques).
* **Allowed torque** of joint j: τ_allowed,j = ``force_limit`` × r_j, r_j the distance from the
  joint's axis to the nearest of the reference points beyond it — the elbow (the elbow joint's
  anchor) for the shoulder joints, the tool flange (``<side>_tool0``) for every joint — at least
  ``min_lever``: a force of ``force_limit`` at either point stays within what the joint allows
  (both points within the limit, the manual's words). A contact nearer the joint than both points
  is allowed more force, the manual's "knee-joint effect" warning — which is why the controller
  has a guard of its own (``wholebody_controller.external_torque``).
* **Trip**: |τ_dev,j| > τ_allowed,j in every physics step for ``detection_time`` (a single-step
  impact spike is not a collision). Then every joint's set point ramps to zero at
  ``stop_deceleration`` and, once there, the arm **holds** the stop position (a position loop
  of ``hold_gain`` on the velocity servo); commands are ignored.
* **Re-arm**: on the robot an operator unlocks a protective stop (pendant, or the dashboard's
  ``unlock protective stop``), which the controller refuses within 5 s of the stop ("Cannot
  unlock protective stop until 5s after occurrence"). Here :meth:`ProtectiveStop.unlock` is that
  unlock (refused within ``unlock_delay``), and with ``auto_unlock`` the simulated operator
  unlocks once ``unlock_delay`` has passed and the deviation has stayed below ``clear_ratio`` of
  the allowed torque for ``clear_time``. After an unlock the arm follows commands again only from
  the first one whose joint speeds are all below ``rearm_velocity`` — phri_hardware's bridge's
  re-arming rule, so a released arm never jumps back to the speed commanded before the stop.

What the arm reports (:meth:`ProtectiveStop.status`) is what the real bridge reads over RTDE:
safety mode ``PROTECTIVE_STOP`` / ``NORMAL``, the protective-stop flag; the bridge publishes it on
``/diagnostics`` as phri_hardware's arm bridge does.
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass, fields

import mujoco
import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class ProtectiveStopConfig:
    """The simulated UR safety system (module docstring).

    Attributes:
        enabled: false: the arms never stop themselves (a robot without the safety system, for
            comparisons).
        force_limit: tool and elbow force limit [N] (UR e-Series safety preset "Default": 150).
        min_lever: least lever arm r_j [m] (a reference point on or near a joint's axis).
        detection_time: a deviation must exceed the allowed torque this long [s].
        stop_deceleration: joint deceleration of the category 2 stop [rad/s²].
        hold_gain: position gain holding the stop position [1/s].
        unlock_delay: no unlock sooner after the stop [s] (UR dashboard: 5 s).
        clear_time: ``auto_unlock`` waits for the deviation to stay low this long [s].
        clear_ratio: "low": below this fraction of the allowed torque.
        auto_unlock: the simulated operator unlocks by the rule above (false: only
            :meth:`ProtectiveStop.unlock`).
        rearm_velocity: after an unlock, commands count from the first one whose joint speeds
            are all below this [rad/s] (phri_hardware ``rearm_velocity``).
    """

    enabled: bool = True
    force_limit: float = 150.0
    min_lever: float = 0.1
    detection_time: float = 0.01
    stop_deceleration: float = 10.0
    hold_gain: float = 10.0
    unlock_delay: float = 5.0
    clear_time: float = 1.0
    clear_ratio: float = 0.5
    auto_unlock: bool = True
    rearm_velocity: float = 0.01

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            if isinstance(value, bool):
                continue
            if not (math.isfinite(value) and value >= 0.0):
                raise ValueError(f"protective stop {f.name} = {value!r}: must be finite, ≥ 0")
        if self.force_limit <= 0.0 or self.min_lever <= 0.0 or self.stop_deceleration <= 0.0:
            raise ValueError("protective stop force_limit, min_lever and stop_deceleration must "
                             "be > 0")


class StopPhase(enum.Enum):
    """One arm's protective-stop state."""

    NORMAL = "normal"
    STOPPING = "stopping"
    """Tripped: the set points ramp to zero."""
    HOLDING = "holding"
    """Stopped: the arm holds the stop position."""
    DISARMED = "disarmed"
    """Unlocked, waiting for a command below ``rearm_velocity``."""


@dataclass(frozen=True)
class StopStatus:
    """What one arm reports (the RTDE view) and why it stopped.

    Attributes:
        protective_stopped: the arm is in a protective stop (STOPPING or HOLDING).
        safety_mode: ``PROTECTIVE_STOP`` or ``NORMAL`` (RTDE ``safety_mode`` names).
        phase: :class:`StopPhase` value.
        stops: protective stops since the start.
        last_joint: the joint that tripped the last stop ("" = none yet).
        last_torque: its deviation then [N·m]; last_allowed: its allowed torque then [N·m].
        stopped_at: sim time of the last stop [s] (nan: none).
    """

    protective_stopped: bool
    safety_mode: str
    phase: str
    stops: int
    last_joint: str
    last_torque: float
    last_allowed: float
    stopped_at: float


class _Arm:
    """One arm's joints in the scene and its stop state."""

    def __init__(self, model: mujoco.MjModel, side: str, joints: tuple[str, ...]) -> None:
        self.side, self.joints = side, joints
        ids = [model.joint(n).id for n in joints]
        self.dofs = np.array([model.jnt_dofadr[j] for j in ids])
        self.qpos = np.array([model.jnt_qposadr[j] for j in ids])
        self.acts = np.array([model.actuator(n + "_vel").id for n in joints])
        self.joint_ids = np.array(ids)
        self.elbow = int(ids[2])
        self.tool = model.body(f"{side}_tool0").id
        self.reset()

    def reset(self) -> None:
        self.phase = StopPhase.NORMAL
        self.setpoint = np.zeros(len(self.joints))
        self.hold = np.zeros(len(self.joints))
        self.over_since = math.nan
        self.stopped_at = math.nan
        self.clear_since = math.nan
        self.stops = 0
        self.last = ("", 0.0, 0.0)
        self.deviation = np.zeros(len(self.joints))
        self.allowed = np.full(len(self.joints), math.inf)


class ProtectiveStop:
    """Both arms' protective stops in one MuJoCo scene (module docstring).

    Args:
        model, data: the scene (the servos are the ``<joint>_vel`` actuators).
        arms: arm side → its six joint names in UR order.
        config: the safety settings.
    """

    def __init__(self, model: mujoco.MjModel, data: mujoco.MjData,
                 arms: dict[str, tuple[str, ...]],
                 config: ProtectiveStopConfig | None = None) -> None:
        self.model, self.data = model, data
        self.config = config or ProtectiveStopConfig()
        self.arms = {side: _Arm(model, side, joints) for side, joints in arms.items()}
        self._scratch = mujoco.MjData(model)
        self._rne = np.zeros(model.nv)
        self._arm_dofs = np.concatenate([a.dofs for a in self.arms.values()])
        self._arm_acts = np.concatenate([a.acts for a in self.arms.values()])
        self._armature = model.dof_armature[self._arm_dofs].copy()
        self._floor = np.full(6, self.config.force_limit * self.config.min_lever)
        self._last_time = math.nan

    def reset(self) -> None:
        """Every arm back to NORMAL with no history (a new run, after settling)."""
        for arm in self.arms.values():
            arm.reset()
        self._last_time = math.nan

    # -- the model's torques -------------------------------------------------------------------
    def _deviations(self) -> None:
        """τ_dev of every arm joint at the current state (module docstring); the allowed
        torques only where a deviation could exceed one (none is below ``force_limit`` ×
        ``min_lever``) or an arm is stopped (its clear test needs them)."""
        m, d, s = self.model, self.data, self._scratch
        dofs = self._arm_dofs
        s.qpos[:] = d.qpos
        s.qvel[:] = 0.0
        s.qacc[:] = 0.0
        s.qvel[dofs] = d.qvel[dofs]
        qacc = d.qacc[dofs]
        s.qacc[dofs] = qacc
        mujoco.mj_kinematics(m, s)
        mujoco.mj_comPos(m, s)
        mujoco.mj_comVel(m, s)
        mujoco.mj_rne(m, s, 1, self._rne)
        deviation = (servo_forces(m, d, self._arm_acts, dofs) + d.qfrc_passive[dofs]
                     - self._rne[dofs] - self._armature * qacc)
        floor = self.config.force_limit * self.config.min_lever
        for i, arm in enumerate(self.arms.values()):
            arm.deviation = deviation[6 * i : 6 * i + 6]
            if arm.phase is StopPhase.NORMAL and float(np.max(np.abs(arm.deviation))) <= floor:
                arm.allowed = self._floor
            else:
                arm.allowed = self._allowed(arm)

    def _allowed(self, arm: _Arm) -> FloatArray:
        """τ_allowed of each joint of ``arm`` [N·m] (module docstring)."""
        d, c = self.data, self.config
        axes, anchors = d.xaxis[arm.joint_ids], d.xanchor[arm.joint_ids]
        lever = _distances_to_axes(d.xpos[arm.tool], anchors, axes)
        lever[:2] = np.minimum(lever[:2], _distances_to_axes(d.xanchor[arm.elbow], anchors[:2],
                                                              axes[:2]))
        return np.asarray(c.force_limit * np.maximum(lever, c.min_lever))

    # -- the safety system ---------------------------------------------------------------------
    def filter(self, side: str, command: FloatArray, sent: FloatArray | None = None
               ) -> FloatArray:
        """The servo set points of arm ``side`` for the next physics step: ``command`` (6 joint
        velocities [rad/s]) while NORMAL, else the stop's ramp or hold. ``sent``: the command as
        the bridge sent it, before the plant's drives (default ``command``) — the re-arming rule
        reads it, as phri_hardware's bridge reads the commands it receives, not the speedJ ramp
        that follows them. Observes the state of the previous step first (call once per arm per
        physics step, in step order)."""
        if not self.config.enabled:
            return np.asarray(command, dtype=np.float64)
        t = float(self.data.time)
        if t != self._last_time:
            self._last_time = t
            self._deviations()
            for arm in self.arms.values():
                self._observe(arm, t)
        arm = self.arms[side]
        if arm.phase is StopPhase.DISARMED:
            if np.max(np.abs(command if sent is None else sent)) <= self.config.rearm_velocity:
                arm.phase = StopPhase.NORMAL
            else:
                return np.zeros_like(command)
        if arm.phase is StopPhase.NORMAL:
            arm.setpoint = np.asarray(command, dtype=np.float64).copy()
            return arm.setpoint
        return self._stop_setpoint(arm)

    def _observe(self, arm: _Arm, t: float) -> None:
        c = self.config
        ratio = np.abs(arm.deviation) / arm.allowed
        worst = int(np.argmax(ratio))
        if arm.phase is StopPhase.NORMAL or arm.phase is StopPhase.DISARMED:
            if ratio[worst] > 1.0:
                if math.isnan(arm.over_since):
                    arm.over_since = t
                if t - arm.over_since >= c.detection_time - 1e-9:
                    self._trip(arm, t, worst)
            else:
                arm.over_since = math.nan
            return
        if ratio[worst] < c.clear_ratio:
            if math.isnan(arm.clear_since):
                arm.clear_since = t
        else:
            arm.clear_since = math.nan
        if (c.auto_unlock and not math.isnan(arm.clear_since)
                and t - arm.clear_since >= c.clear_time - 1e-9):
            self.unlock(arm.side)

    def _trip(self, arm: _Arm, t: float, joint: int) -> None:
        arm.phase = StopPhase.STOPPING
        arm.stopped_at = t
        arm.over_since = math.nan
        arm.clear_since = math.nan
        arm.stops += 1
        arm.last = (arm.joints[joint], float(arm.deviation[joint]), float(arm.allowed[joint]))
        arm.hold = self.data.qpos[arm.qpos].copy()

    def _stop_setpoint(self, arm: _Arm) -> FloatArray:
        """The category 2 stop: ramp every set point to zero, then hold the stop position."""
        c = self.config
        dt = float(self.model.opt.timestep)
        if arm.phase is StopPhase.STOPPING:
            step = c.stop_deceleration * dt
            arm.setpoint = np.sign(arm.setpoint) * np.maximum(np.abs(arm.setpoint) - step, 0.0)
            arm.hold = self.data.qpos[arm.qpos].copy()
            if not np.any(arm.setpoint):
                arm.phase = StopPhase.HOLDING
            return arm.setpoint.copy()
        return c.hold_gain * (arm.hold - self.data.qpos[arm.qpos])

    def unlock(self, side: str) -> tuple[bool, str]:
        """Unlock arm ``side``'s protective stop (the operator's unlock): refused while none is
        active or within ``unlock_delay`` of the stop. Returns (done, message)."""
        arm = self.arms[side]
        if arm.phase not in (StopPhase.STOPPING, StopPhase.HOLDING):
            return False, f"{side} arm: no protective stop to unlock"
        elapsed = float(self.data.time) - arm.stopped_at
        if elapsed < self.config.unlock_delay - 1e-9:
            return False, (f"{side} arm: cannot unlock protective stop until "
                           f"{self.config.unlock_delay:g}s after occurrence "
                           f"({elapsed:.2f} s so far)")
        arm.phase = StopPhase.DISARMED
        arm.clear_since = math.nan
        arm.setpoint = np.zeros(len(arm.joints))
        return True, f"{side} arm: protective stop unlocked"

    def status(self, side: str) -> StopStatus:
        """What arm ``side`` reports now (:class:`StopStatus`)."""
        arm = self.arms[side]
        stopped = arm.phase in (StopPhase.STOPPING, StopPhase.HOLDING)
        joint, torque, allowed = arm.last
        return StopStatus(stopped, "PROTECTIVE_STOP" if stopped else "NORMAL", arm.phase.value,
                          arm.stops, joint, torque, allowed, arm.stopped_at)

    def deviation(self, side: str) -> tuple[FloatArray, FloatArray]:
        """(τ_dev, τ_allowed) of arm ``side``'s joints at the last observation [N·m]."""
        arm = self.arms[side]
        return arm.deviation.copy(), arm.allowed.copy()


def servo_forces(model: mujoco.MjModel, data: mujoco.MjData, actuators: NDArray[np.int_],
                 dofs: NDArray[np.int_]) -> FloatArray:
    """The force [N] or torque [N·m] each velocity servo applied over the last physics step:
    k_v (u − q̇) at the step's end velocity, within the servo's force range. MuJoCo's implicit
    integrator applies the servo's damping-like force at the end velocity; ``actuator_force`` is
    the start-of-step value, which overstates a transient by the factor 1 + dt·k_v/m (≈ 1.5 on
    the base, up to 6 on an arm joint)."""
    kv = model.actuator_gainprm[actuators, 0]
    force = kv * (data.ctrl[actuators] - data.qvel[dofs])
    low, high = model.actuator_forcerange[actuators, 0], model.actuator_forcerange[actuators, 1]
    return np.asarray(np.clip(force, low, high))


def _distances_to_axes(point: FloatArray, anchors: FloatArray, axes: FloatArray) -> FloatArray:
    """Distance [m] of ``point`` from each line through ``anchors[k]`` along the unit
    ``axes[k]``."""
    r = point - anchors
    along = np.einsum("ij,ij->i", r, axes)
    return np.asarray(np.linalg.norm(r - along[:, None] * axes, axis=1))


__all__ = ["ProtectiveStop", "ProtectiveStopConfig", "StopPhase", "StopStatus", "servo_forces"]
