"""The robot inside the simulation: its joints in MjModel/MjData, its state and its servos (pure).

Configuration q (15): the base pose q_b = [x, y, yaw] of ``base_link`` in ``odom`` [m, rad], then
the left and the right arm in UR order [rad]. The base follows a body twist (v_x, v_y, ω_z) through
velocity servos on its three planar joints, whose set points are the world rates::

    ẋ = cos(yaw) v_x − sin(yaw) v_y,   ẏ = sin(yaw) v_x + cos(yaw) v_y,   ẏaw = ω_z

and each arm joint follows its commanded velocity through a stiff velocity servo (scene.py),
through the arm's own protective stop (:mod:`~phri_sim.world.protective_stop`: the UR stops itself
on a collision, whatever link it is on). Between
the command and the servos sits :attr:`SimRobot.shaper` when set: the plant's drives
(:class:`phri_sim.world.actuators.CommandShaper`: latency, ramps, lag), one call per physics step.

Efforts (:meth:`SimRobot.efforts`): what each drive applies, as ``/joint_states`` ``effort``
carries it — the base servos' force along odom x, y [N] and torque about the vertical [N·m], and
each arm joint's servo torque plus the gravity torque its drive carries [N·m] (the arm is
gravity-compensated in the model; a real UR's drive carries it, and RTDE's torques include it).
"""

from __future__ import annotations

from collections.abc import Callable

import mujoco
import numpy as np
from numpy.typing import NDArray

from phri_common.planar import base_to_world, world_to_base
from phri_description.description import JOINT_NAMES, RobotDescription
from phri_sim.world.protective_stop import ProtectiveStop, ProtectiveStopConfig, servo_forces
from phri_sim.world.scene import ACTUATOR_SUFFIX

FloatArray = NDArray[np.float64]

ARM_SIDES: tuple[str, str] = ("left", "right")
ARM_JOINTS: dict[str, tuple[str, ...]] = {
    side: tuple(n for n in JOINT_NAMES[3:] if n.startswith(side + "_")) for side in ARM_SIDES
}
"""Joint names per arm in UR order (the order of the arm command arrays)."""


class SimRobot:
    """The mecanum base and the two arms in a MuJoCo scene (module docstring).

    Attributes:
        joint_names: the 15 names of q, in order.
        position_limits: (15, 2) lower/upper position limits [m, rad] (base unbounded).
        velocity_limits: (15,) symmetric speed limits [m/s, rad/s], body twist for the base.
    """

    def __init__(self, model: mujoco.MjModel, data: mujoco.MjData,
                 description: RobotDescription,
                 protective_stop: ProtectiveStopConfig | None = None) -> None:
        """``protective_stop``: the arms' UR safety settings (``None``: the defaults)."""
        self.model, self.data = model, data
        self.joint_names = JOINT_NAMES
        self._qpos = np.array([model.jnt_qposadr[model.joint(n).id] for n in JOINT_NAMES])
        self._dofs = np.array([model.jnt_dofadr[model.joint(n).id] for n in JOINT_NAMES])
        act = np.array([model.actuator(n + ACTUATOR_SUFFIX).id for n in JOINT_NAMES])
        self._yaw_qpos = int(self._qpos[2])
        self._act_x, self._act_y = int(act[0]), int(act[1])
        self._act_rest = act[2:]
        self._act_yaw, self._act_arms = int(act[2]), act[3:]
        self._acts = act
        self.protective_stop = ProtectiveStop(model, data, ARM_JOINTS, protective_stop)
        """Both arms' protective stops (the UR's own safety system)."""
        self.position_limits = description.position_limits()
        self.velocity_limits = description.velocity_limits()
        self.shaper: Callable[[FloatArray], FloatArray] | None = None
        """The plant's drives (:class:`phri_sim.world.actuators.CommandShaper`): the 15 commands
        → the 15 servo set points of the next physics step; ``None`` = the servos follow the
        commands at once (the ideal plant)."""

    @property
    def q(self) -> FloatArray:
        """Configuration (15) [m, rad]: base x, y, yaw then the arms."""
        return np.asarray(self.data.qpos[self._qpos], dtype=np.float64)

    @property
    def qd(self) -> FloatArray:
        """Joint rates (15): world rates ẋ, ẏ, ẏaw then arm joint velocities."""
        return np.asarray(self.data.qvel[self._dofs], dtype=np.float64)

    def set_q(self, q: FloatArray) -> None:
        """Put the robot at configuration ``q`` (15 finite values) [m, rad]."""
        q = np.asarray(q, dtype=np.float64)
        if q.shape != (len(JOINT_NAMES),) or not np.all(np.isfinite(q)):
            raise ValueError(f"q must be {len(JOINT_NAMES)} finite numbers, got {q.tolist()}")
        self.data.qpos[self._qpos] = q

    def hold(self, q: FloatArray) -> None:
        """Pin the robot at ``q`` (as read from :attr:`q`) at rest: zero joint rates."""
        self.data.qpos[self._qpos] = q
        self.data.qvel[self._dofs] = 0.0

    def base_twist(self) -> FloatArray:
        """Base body-frame twist [v_x, v_y, ω_z] [m/s, rad/s] (inverse of the module's map)."""
        qd, yaw = self.qd, float(self.q[2])
        vx, vy = world_to_base(yaw, float(qd[0]), float(qd[1]))
        return np.array([vx, vy, qd[2]])

    def link_pose(self, link: str) -> tuple[FloatArray, FloatArray]:
        """(⁰R 3×3, ⁰p [m]) of a link frame (body frame = description link frame)."""
        b = self.model.body(link).id
        return self.data.xmat[b].reshape(3, 3).copy(), self.data.xpos[b].copy()

    def drive(self, u: FloatArray) -> None:
        """Servo set points from the 15 commanded velocities ``u``: body twist [m/s, rad/s] turned
        into world rates at the current yaw (module docstring), then the arm joints [rad/s]; through
        :attr:`shaper` when set (once per physics step)."""
        sent = u
        if self.shaper is not None:
            u = self.shaper(u)
        d = self.data
        yaw = float(d.qpos[self._yaw_qpos])
        ctrl = d.ctrl
        ctrl[self._act_x], ctrl[self._act_y] = base_to_world(yaw, float(u[0]), float(u[1]))
        ctrl[self._act_yaw] = u[2]
        stop = self.protective_stop
        ctrl[self._act_arms] = np.concatenate([
            stop.filter(side, u[3 + 6 * i : 9 + 6 * i], sent[3 + 6 * i : 9 + 6 * i])
            for i, side in enumerate(ARM_SIDES)])

    def efforts(self) -> FloatArray:
        """What each drive applied over the last physics step (15; module docstring): base x, y
        [N], yaw [N·m], then the arm joints [N·m], gravity included (the servos' forces:
        :func:`~phri_sim.world.protective_stop.servo_forces`)."""
        out = servo_forces(self.model, self.data, self._acts, self._dofs)
        out[3:] += self.data.qfrc_gravcomp[self._dofs[3:]]
        return out
