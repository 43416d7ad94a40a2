"""Straightforward numpy reference of the control step (test-only).

An array-per-operation implementation of (10)–(23) and Algorithm 1, written independently of the
float code of :mod:`wholebody_controller.contact_task` and :mod:`wholebody_controller.controller`:
its SO(3) maps come from scipy (``wbc_rotations``), not from ``so3.py``, so an error in a
production coefficient cannot hide in both. It is the oracle of ``test_equivalence.py``: on random
inputs the fast path must agree with it to 1e-9. Readability over speed.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from wbc_rotations import exp_rotvec, log_rotation, world_angular_velocity

from phri_common.records import ContactState
from wholebody_controller.admittance import discretise
from wholebody_controller.config import ControllerConfig, LinkTaskConfig, diag6
from wholebody_controller.contact_task import Phase
from wholebody_controller.controller import KinematicsModel
from wholebody_controller.qp import QPProblem, QPSolver, build_qp, make_solver, velocity_bounds

Array = NDArray[np.float64]
_ZERO3 = np.zeros(3)


class RefAdmittance:
    """s⁺ = Φ s + Γ w with full matrices."""

    def __init__(self, config: LinkTaskConfig, dt: float) -> None:
        g = config.admittance
        self.phi, self.gamma = discretise(diag6(g.inertia), diag6(g.damping),
                                          diag6(g.stiffness), dt)
        self.state = np.zeros(12)

    def step(self, wrench: Array) -> None:
        self.state = self.phi @ self.state + self.gamma @ wrench


@dataclass
class RefOutput:
    phase: Phase
    psi: float
    psi_raw: float
    point: Array
    target: Array
    control_velocity: Array
    wrench: Array
    track_force: Array
    deflection: Array
    deflection_velocity: Array
    in_contact: bool


class RefTask:
    """Algorithm 1 and (10)–(20) of one link, numpy arrays throughout."""

    def __init__(self, config: LinkTaskConfig, cc: ControllerConfig) -> None:
        self.config = config
        self.k_eta, self.b, self.k_p, self.psi_thr = cc.k_eta, cc.b, cc.k_p, cc.psi_thr
        self.margin, self.dt = cc.region_margin, cc.dt
        self.adm = RefAdmittance(config, cc.dt)
        self.psi_prev = 0.0
        self.point = np.zeros(3)
        self.had_contact = False
        self.ref_rot: Array | None = None
        self.ref_pos: Array | None = None
        self.dmin: Array | None = None
        self.dmax: Array | None = None

    def update(self, contact: ContactState, rot: Array, pos: Array, yaw: float) -> RefOutput:
        in_contact = bool(contact.in_contact)
        rate = None
        if in_contact:
            center = np.asarray(contact.center, dtype=np.float64)
            if self.had_contact:
                rate = (center - self.point) / self.dt
            self.point = center
        elif self.had_contact:
            self.dmin = self.dmax = None
        self.had_contact = in_contact
        point = self.point
        mu = np.zeros(3)
        wrench = np.zeros(6)
        if in_contact:
            local_force = np.asarray(contact.force, dtype=np.float64)
            if self.dmin is not None and self.dmax is not None:
                mu_local = (np.maximum(contact.region_max - self.dmax, 0.0)
                            - np.maximum(self.dmin - contact.region_min, 0.0))
                mu = rot @ mu_local
                local_force = local_force + self.k_eta * mu_local
            wrench[0:3] = rot @ local_force
            wrench[3:6] = rot @ contact.torque
        fx, fy, fz = self.config.desired_force
        c, s = math.cos(yaw), math.sin(yaw)
        wrench[0:3] += np.array([c * fx - s * fy, s * fx + c * fy, fz])

        self.adm.step(wrench)
        lock = self.config.priority_lock
        dv_all = self.adm.state[6:12]
        psi_raw = lock if lock is not None else math.tanh(0.5 * self.b * float(dv_all @ dv_all))
        thr = self.psi_thr
        activating = self.psi_prev <= thr < psi_raw
        deactivated = self.psi_prev >= thr > psi_raw
        if activating:
            self.ref_rot, self.ref_pos = rot.copy(), pos.copy()
            if self.config.reference is not None:
                ref = np.asarray(self.config.reference, dtype=float)
                self.ref_rot, self.ref_pos = ref[:9].reshape(3, 3), ref[9:12].copy()
        if deactivated:
            self.adm.state = np.zeros(12)
            self.ref_rot = self.ref_pos = None
            self.dmin = self.dmax = None
        self.psi_prev = psi_raw
        active = psi_raw >= thr and self.ref_rot is not None
        if active and in_contact and self.dmin is None:
            user = self.config.desired_region
            if user is not None:
                self.dmin, self.dmax = np.asarray(user[0], float), np.asarray(user[1], float)
            else:
                self.dmin = contact.region_min - self.margin
                self.dmax = contact.region_max + self.margin
        if not active:
            self.adm.state[0:6] = 0.0
        defl = self.adm.state[0:6].copy()
        dv = self.adm.state[6:12].copy()
        target = np.zeros(6)
        control = np.zeros(6)
        phase = Phase.INACTIVE
        if active:
            assert self.ref_rot is not None and self.ref_pos is not None
            phase = Phase.ACTIVATING if activating else (
                Phase.ACTIVE if in_contact or lock is not None else Phase.DEACTIVATING)
            rot_d = exp_rotvec(defl[3:6]) @ self.ref_rot
            omega_d = world_angular_velocity(defl[3:6], dv[3:6])
            rd_p = rot_d @ point
            target[0:3] = (self.k_p * (self.ref_pos + defl[0:3] - pos + rd_p - rot @ point)
                           + dv[0:3] + np.cross(omega_d, rd_p))
            target[3:6] = self.k_p * log_rotation(rot_d @ rot.T) + omega_d
            control = target.copy()
            if rate is not None:
                control[0:3] += rot_d @ rate
                target[0:3] += rot_d @ rate - rot @ rate
        return RefOutput(phase, max(psi_raw, thr), psi_raw, point.copy(), target, control, wrench,
                         self.k_eta * mu, defl, dv, in_contact)


@dataclass
class RefStep:
    command: Array
    qdot: Array
    tasks: list[RefOutput]
    tracking_errors: list[Array]
    problem: QPProblem


class RefController:
    """The whole step: tasks, Jacobians, base-frame column rotation, QP (22)–(23)."""

    def __init__(self, kin: KinematicsModel, config: ControllerConfig,
                 solver: QPSolver | None = None) -> None:
        self.kin, self.config = kin, config
        self.tasks = [RefTask(link, config) for link in config.links]
        self.solver = solver or make_solver(config.solver)
        limits = np.asarray(kin.position_limits, dtype=np.float64)
        self.lower, self.upper = limits[:, 0].copy(), limits[:, 1].copy()
        names = list(kin.joint_names)
        for rng in config.joint_ranges:
            i = names.index(rng.joint)
            self.lower[i] = max(self.lower[i], rng.lower)
            self.upper[i] = min(self.upper[i], rng.upper)
        self.vmax = np.minimum(np.asarray(kin.velocity_limits, float), config.velocity_limit)

    def step(self, q: Array, contacts: Mapping[str, ContactState]) -> RefStep:
        self.kin.update(q)
        yaw = float(q[2])
        outs, jacs = [], []
        for task in self.tasks:
            link = task.config.link
            contact = contacts.get(link) or ContactState.no_contact(link, 0)
            rot, pos = self.kin.link_pose(link)
            out = task.update(contact, rot, pos, yaw)
            outs.append(out)
            jacs.append(self.kin.point_jacobian(link, out.point))
        stacked = np.concatenate(jacs)
        c, s = math.cos(yaw), math.sin(yaw)
        stacked[:, 0:2] = stacked[:, 0:2] @ np.array(((c, -s), (s, c)))
        lo, hi = velocity_bounds(q, self.lower, self.upper, -self.vmax, self.vmax,
                                 self.config.horizon)
        target = np.concatenate([o.target for o in outs])
        problem = build_qp([stacked], [target], [o.psi for o in outs], self.config.epsilon,
                           lo, hi)
        command = self.solver.solve(problem)
        residual = target - stacked @ command
        qdot = command.copy()
        qdot[0] = c * command[0] - s * command[1]
        qdot[1] = s * command[0] + c * command[1]
        return RefStep(command, qdot, outs, [residual[6 * i: 6 * i + 6] for i in range(len(outs))],
                       problem)
