"""External joint torques of the arms from their own readings, and the part the skin explains
(pure: MuJoCo for the rigid-body model, no rclpy).

The skin covers three links; a contact anywhere else on an arm — a wrist, the shoulder, the far
side of a link — is felt only by the arm's joints. Each arm reports the torque its drives apply
in ``/joint_states`` ``effort`` (docs/interfaces.md, "Joint efforts"): the simulator's velocity
servos, a real UR16e what RTDE reports. The model of this module:

* **What the motion needs.** The rigid-body equation of the robot (mobile base as x, y, yaw
  joints, both arms; masses and inertias of :mod:`phri_description`) is
  ``M(q) q̈ + c(q, q̇) + g(q) = τ_drive + τ_ext``, so on the arm joints

      τ_ext = [M(q) q̈ + c(q, q̇) + g(q)]_arm − τ_drive     (E1)

  the inverse dynamics (``mj_rne``) at the measured q, q̇ and an acceleration estimated by
  differencing the measured velocities, minus the measured efforts. The base's own motion enters
  through its rows of q̇, q̈ (differenced odometry): a base accelerating at 1 m/s² needs some
  10 N·m on a shoulder, which is not a contact.
* **Efforts include gravity.** ``effort`` is the torque the drive applies, gravity included — what
  a UR's drive carries and RTDE's ``actual_current_as_torque`` reports; the simulated arms are
  gravity-compensated by the model, and the simulator adds that torque back into ``effort``
  (phri_sim ``SimRobot.efforts``). (E1) removes it with g(q), so gravity is never read as a contact;
  a wrong payload or mounting on a real arm would be (a bias, as for the UR's own collision
  detection, which needs the payload set right too).
* **Not modelled**: rotor inertia (the simulator's armature 0.05–0.5 kg·m²: ≤ 1 N·m at the rated
  2 rad/s²) and joint friction (none in the simulator; on a real UR its model removes some of it
  in ``get_joint_torques()``, docs/interfaces.md): the thresholds of the guard stay well above.
* **What the skin explains.** A skin link's contact state carries the force f and the torque τ
  about its contact centre p (link frame); on the arm joints it causes ``Jᵀ(p) [f; τ]`` (world
  frame, J the point Jacobian of the link at p, eq. 8). The sum over the skin links is
  :func:`skin_torques`; ``τ_ext − τ_skin`` is the torque no skin explains (:func:`unexplained`):
  a contact on an unsensed link, or a skin that misreads.

:class:`ArmDynamics` evaluates both on its own MuJoCo model (its own ``MjData``: it never touches
the controller's kinematics). :class:`ExternalTorqueEstimator` keeps the latest readings, the
differenced rates and a first-order low-pass of τ_ext (``filter_time``). The skin's check
against the joints (gain far off, skin silent) is :mod:`~wholebody_controller.skin_torque_check`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import mujoco
import numpy as np
from numpy.typing import NDArray

from phri_common.records import ContactState
from phri_description.description import JOINT_NAMES, RobotDescription, robot_description
from phri_description.mujoco_model import build_model, dof_indices, qpos_indices
from wholebody_controller.skin_torque_check import expected_joint_torques

FloatArray = NDArray[np.float64]

ARM_JOINTS: tuple[str, ...] = JOINT_NAMES[3:]
"""The 12 arm joints, left then right, UR order."""
ARMS: tuple[str, ...] = ("left", "right")
N_Q = len(JOINT_NAMES)
"""15: every vector here is in q order — the base's x, y [N] and yaw [N·m] (world frame: the
forces along odom x, y and the torque about the vertical), then the arm joints [N·m]."""


class ArmDynamics:
    """The robot's rigid-body model for (E1) and the skin's joint torques (module docstring).

    Args:
        description: the robot (default: phri_description's).
    """

    def __init__(self, description: RobotDescription | None = None) -> None:
        desc = description or robot_description()
        self.model = build_model(desc, geoms=False)
        self.data = mujoco.MjData(self.model)
        names = tuple(desc.joint_names)
        if names[3:] != ARM_JOINTS:
            raise ValueError(f"ArmDynamics needs the arm joints {ARM_JOINTS}, got {names[3:]}")
        self._qadr = qpos_indices(self.model, names)
        self._dadr = dof_indices(self.model, names)
        self._rne = np.zeros(self.model.nv)
        self._jacp = np.zeros((3, self.model.nv))
        self._jacr = np.zeros((3, self.model.nv))
        self.link_torques: dict[str, FloatArray] = {}
        """Each skin link's share of the last :meth:`skin_torques` [N, N·m] (15)."""

    def needed(self, q: FloatArray, qd: FloatArray, qdd: FloatArray) -> FloatArray:
        """M q̈ + c + g on the 15 joints [N, N·m] at configuration ``q``, rates ``qd`` and
        accelerations ``qdd`` (15 each: base x, y, yaw world rates, then the arms)."""
        m, d = self.model, self.data
        d.qpos[self._qadr] = q
        d.qvel[self._dadr] = qd
        d.qacc[self._dadr] = qdd
        mujoco.mj_kinematics(m, d)
        mujoco.mj_comPos(m, d)
        mujoco.mj_comVel(m, d)
        mujoco.mj_rne(m, d, 1, self._rne)
        return np.asarray(self._rne[self._dadr], dtype=np.float64)

    def skin_torques(self, q: FloatArray, contacts: Mapping[str, ContactState]) -> FloatArray:
        """Σ Jᵀ(p) [f; τ] over the links in contact [N, N·m] (15; module docstring) at
        configuration ``q`` (15). A link the model does not know is skipped. Each link's share
        is kept in :attr:`link_torques`."""
        m, d = self.model, self.data
        d.qpos[self._qadr] = q
        mujoco.mj_kinematics(m, d)
        mujoco.mj_comPos(m, d)
        total = np.zeros(N_Q)
        self.link_torques = {}
        cols = self._dadr
        for link, state in contacts.items():
            if not state.in_contact:
                continue
            try:
                body = m.body(link).id
            except KeyError:
                continue
            rot = d.xmat[body].reshape(3, 3)
            point = rot @ state.center + d.xpos[body]
            mujoco.mj_jac(m, d, self._jacp, self._jacr, point, body)
            jac = np.vstack([self._jacp[:, cols], self._jacr[:, cols]])
            share = expected_joint_torques([jac], [np.concatenate([rot @ state.force,
                                                                   rot @ state.torque])])
            self.link_torques[link] = share
            total += share
        return total


def unexplained(measured: FloatArray, skin: FloatArray) -> FloatArray:
    """τ_ext − τ_skin [N·m]: the external torque no skin contact explains."""
    return np.asarray(measured - skin, dtype=np.float64)


class ExternalTorqueEstimator:
    """Latest readings → τ_ext of the 15 joints (E1), low-pass filtered.

    The node hands it every joint state (:meth:`joints`: names, positions, velocities, efforts,
    with the arrival time) and every odometry pose (:meth:`base`). Accelerations are the
    differences of successive velocities (per reading, so a slower publisher does not read as
    a step). The base's rates come from the joint state when it names the base joints with
    velocities (the simulator's), else from differenced odometry. τ_ext is updated with each
    joint state that carries efforts and filtered by a first-order low-pass of time constant
    ``filter_time`` [s] (0: unfiltered). A joint without an effort reading has τ_ext = 0
    (:attr:`sensed` says which have one).
    """

    def __init__(self, dynamics: ArmDynamics, filter_time: float = 0.02) -> None:
        self.dynamics = dynamics
        self.filter_time = filter_time
        self._index = {name: i for i, name in enumerate(JOINT_NAMES)}
        self.reset()

    def reset(self) -> None:
        """Forget every reading."""
        self.q, self.qd, self.qdd = np.zeros(N_Q), np.zeros(N_Q), np.zeros(N_Q)
        self.effort = np.zeros(N_Q)
        self.sensed = np.zeros(N_Q, dtype=bool)
        self.tau = np.zeros(N_Q)
        self._rate_time = np.full(N_Q, math.nan)
        self._base_rates_from_joints = False
        self._pose_time = math.nan
        self._tau_time = math.nan

    def base(self, t: float, pose: Sequence[float]) -> None:
        """An odometry pose [x, y, yaw] [m, rad] at time ``t`` [s]; base rates and accelerations
        by difference unless the joint states carry them."""
        pose_a = np.asarray(pose, dtype=np.float64)
        dt = t - self._pose_time
        if dt > 0.0 and not self._base_rates_from_joints:
            delta = pose_a - self.q[:3]
            delta[2] = math.remainder(float(delta[2]), math.tau)
            self._rate(slice(0, 3), delta / dt, dt)
        self.q[:3] = pose_a
        self._pose_time = t

    def _rate(self, index: slice | int, rate: FloatArray | float, dt: float) -> None:
        self.qdd[index] = (rate - self.qd[index]) / dt
        self.qd[index] = rate

    def joints(self, t: float, names: Sequence[str], position: Sequence[float],
               velocity: Sequence[float], effort: Sequence[float]) -> None:
        """A joint state at time ``t`` [s]: names, positions [rad, m], velocities [rad/s, m/s]
        and efforts [N·m, N] (each may be empty; unknown names are ignored). Updates τ_ext when
        any joint carried an effort."""
        has_v, has_e = len(velocity) == len(names), len(effort) == len(names)
        updated = False
        for k, name in enumerate(names):
            i = self._index.get(name)
            if i is None:
                continue
            self.q[i] = position[k]
            if has_v:
                dt = t - self._rate_time[i]
                if dt > 0.0:
                    self._rate(i, velocity[k], dt)
                elif math.isnan(dt):
                    self.qd[i] = velocity[k]
                self._rate_time[i] = t
                self._base_rates_from_joints |= i < 3
            if has_e and math.isfinite(effort[k]):
                self.effort[i] = effort[k]
                self.sensed[i] = True
                updated = True
        if updated:
            self._update(t)

    def _update(self, t: float) -> None:
        raw = self.dynamics.needed(self.q, self.qd, self.qdd) - self.effort
        raw[~self.sensed] = 0.0
        dt = t - self._tau_time
        if self.filter_time > 0.0 and dt >= 0.0 and math.isfinite(dt):
            alpha = 1.0 - math.exp(-dt / self.filter_time)
            self.tau += alpha * (raw - self.tau)
        else:
            self.tau = raw
        self._tau_time = t

    def skin(self, q: FloatArray, contacts: Mapping[str, ContactState]) -> FloatArray:
        """The skin's share of the joint torques [N, N·m] (15) at configuration ``q``."""
        return self.dynamics.skin_torques(q, contacts)


__all__ = ["ARMS", "ARM_JOINTS", "N_Q", "ArmDynamics", "ExternalTorqueEstimator", "unexplained"]
