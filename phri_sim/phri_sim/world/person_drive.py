"""The person inside the simulation: body parts pulled to scripted targets (pure, no rclpy).

Every physics step each part receives the spring–damper wrench of :mod:`phri_sim.world.person_body`
towards its target; the target position moves on with its scripted velocity from when it was set::

    p_target(t) = p_set + v_target (t − t_set)                                     [m]
    F = K_lin (p_target(t) − p) + D_lin (v_target − v)                              [N]
    F_xy ← F_xy · min(1, F_max / ‖F_xy‖)        (a person who stops pushing, person_body.py)
    τ = R (K_rot subQuat(q_target, q) − D_rot ω_body)                             [N·m]

(``mju_subQuat`` gives the body-frame rotation vector from the current to the target orientation;
the free joint's angular velocity ω_body is body-frame; R turns the torque into the world frame),
so a script evaluated once per control period still drives a smooth target.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np
from numpy.typing import NDArray

from phri_common.planar import quaternion_from_yaw
from phri_sim.world.person_body import BodyPartSpec, PartTarget

FloatArray = NDArray[np.float64]


class SimPerson:
    """The person's parts in a MuJoCo scene, their targets and spring wrenches (module docstring).

    Attributes:
        parts: the part specifications, in ground-truth order.
        part_body, part_qpos, part_dof: per part name, its body id and the qpos / dof address of
            its free joint.
        targets: the latest target per part name.
        geom_part: every geom of the person (including those on a tissue layer) → its part.
    """

    def __init__(self, model: mujoco.MjModel, data: mujoco.MjData,
                 parts: tuple[BodyPartSpec, ...]) -> None:
        m = model
        self.data = data
        self.parts = parts
        self.part_body = {p.name: m.body(p.name).id for p in parts}
        self.part_qpos = {p.name: m.jnt_qposadr[m.joint(p.name + "_free").id] for p in parts}
        self.part_dof = {p.name: m.jnt_dofadr[m.joint(p.name + "_free").id] for p in parts}
        self.geom_part = {g: p for p in parts for g in range(m.ngeom)
                          if m.body_rootid[m.geom_bodyid[g]] == self.part_body[p.name]}
        self._index = {p.name: i for i, p in enumerate(parts)}
        self._bodies = [int(self.part_body[p.name]) for p in parts]
        self._dofs = [int(self.part_dof[p.name]) for p in parts]
        self._k_lin = np.array([p.stiffness for p in parts])
        self._d_lin = np.array([p.damping for p in parts])
        self._k_rot = np.array([p.rot_stiffness for p in parts])
        self._d_rot = np.array([p.rot_damping for p in parts])
        self._max_push = np.array([p.max_push for p in parts])
        n = len(parts)
        self._target_pos, self._target_vel = np.zeros((n, 3)), np.zeros((n, 3))
        self._target_time = np.zeros(n)
        self._target_cos, self._target_sin = np.ones(n), np.zeros(n)
        self._body_index = np.array(self._bodies, dtype=np.intp)
        self._lin_dofs = np.array(self._dofs, dtype=np.intp)[:, None] + np.arange(3)
        self._rot_dofs = self._lin_dofs + 3
        self._k_lin_col, self._d_lin_col = self._k_lin[:, None], self._d_lin[:, None]
        self._k_rot_col, self._d_rot_col = self._k_rot[:, None], self._d_rot[:, None]
        self._rot_err, self._quat = np.zeros((n, 3)), np.zeros(4)
        self._torque_world = np.zeros(3)
        self._tissue_qpos: dict[str, list[int]] = {}
        self._tissue_dofs: dict[str, list[int]] = {}
        for p in parts:
            if p.tissue is not None:
                axes = ("x", "y", "yaw") if p.tissue.yaw_stiffness > 0.0 else ("x", "y")
                joints = [m.joint(f"{p.tissue_body}_{a}").id for a in axes]
                self._tissue_qpos[p.name] = [int(m.jnt_qposadr[j]) for j in joints]
                self._tissue_dofs[p.name] = [int(m.jnt_dofadr[j]) for j in joints]
        self.targets: dict[str, PartTarget] = {}
        for p in parts:
            self.set_target(p.name, PartTarget(np.array(p.parking), np.zeros(3)))

    def set_target(self, part: str, target: PartTarget, *, teleport: bool = False) -> None:
        """Set a part's spring target (from now on it moves with ``target.velocity`` until the
        next call); ``teleport`` also moves the part there at rest."""
        i = self._index.get(part)
        if i is None:
            raise KeyError(f"no person part {part!r}; parts: {sorted(self._index)}")
        self.targets[part] = target
        self._target_pos[i] = target.position
        self._target_vel[i] = target.velocity
        self._target_time[i] = self.data.time
        w, _, _, z = quaternion_from_yaw(target.yaw)
        self._target_cos[i], self._target_sin[i] = w, z
        if teleport:
            self._place(part, target)

    def reset(self) -> None:
        """Every part at rest at its current target (its ``rest`` point if it has one), and the
        targets' clock back to 0 (call after the scene's time was reset)."""
        for name, target in self.targets.items():
            self._place(name, target)
        self.restart_clock()

    def restart_clock(self) -> None:
        """The targets were set at time 0: call when the simulation clock is set back to 0."""
        self._target_time[:] = 0.0

    def _place(self, name: str, target: PartTarget) -> None:
        adr = self.part_qpos[name]
        self.data.qpos[adr : adr + 3] = target.position if target.rest is None else target.rest
        self.data.qpos[adr + 3 : adr + 7] = quaternion_from_yaw(target.yaw)
        dof = self.part_dof[name]
        self.data.qvel[dof : dof + 6] = 0.0
        if name in self._tissue_qpos:
            self.data.qpos[self._tissue_qpos[name]] = 0.0
            self.data.qvel[self._tissue_dofs[name]] = 0.0

    def part_pose(self, part: str) -> tuple[FloatArray, FloatArray]:
        """(position [m], quaternion w x y z) of a part in the world."""
        b = self.part_body[part]
        return self.data.xpos[b].copy(), self.data.xquat[b].copy()

    def apply_wrenches(self, t: float) -> None:
        """Write every part's spring–damper wrench at sim time ``t`` [s] (module docstring) into
        ``xfrc_applied`` [N, N·m].

        The forces of all parts in one set of array operations (element by element the same
        arithmetic as part by part, so bit-identical); the torques through MuJoCo's quaternion
        functions, part by part."""
        d = self.data
        xfrc, xquat, qvel = d.xfrc_applied, d.xquat, d.qvel
        bodies = self._body_index
        vel = self._target_vel
        lag = (t - self._target_time)[:, None]
        force = self._k_lin_col * (self._target_pos + vel * lag - d.xpos[bodies]) + (
            self._d_lin_col * (vel - qvel[self._lin_dofs]))
        for i, fx in enumerate(force[:, 0].tolist()):
            push = math.hypot(fx, force[i, 1])
            if push > self._max_push[i]:  # person_body.py, "A person who stops pushing"
                force[i, 0:2] *= self._max_push[i] / push
        xfrc[bodies, 0:3] = force
        torque_body = self._k_rot_col * self._rot_errors(xquat) - (
            self._d_rot_col * qvel[self._rot_dofs])
        world = self._torque_world
        for i, b in enumerate(self._bodies):
            mujoco.mju_rotVecQuat(world, torque_body[i], xquat[b])
            xfrc[b, 3:6] = world

    def _rot_errors(self, xquat: FloatArray) -> FloatArray:
        """(n, 3) body-frame rotation vectors from each part's orientation to its target's
        (``mju_subQuat``)."""
        err, quat = self._rot_err, self._quat
        for i, b in enumerate(self._bodies):
            quat[0], quat[3] = self._target_cos[i], self._target_sin[i]
            mujoco.mju_subQuat(err[i], quat, xquat[b])
        return err
