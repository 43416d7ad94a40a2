"""Straightforward numpy reference of the control step (test-only).

An array-per-operation implementation of (10)–(23), Algorithm 1 and everything the controller
adds around them — the contact safety (graded force response, regain budget of a desired force),
the lead moment and carried reference, the desired region's onset window and hysteresis, the
admittance input's dead zone —
written independently of the production step: its SO(3) maps come from scipy
(``wbc_rotations``), not from ``so3.py``, and every rule is written here again from the
documentation (module docstrings of ``contact_safety``, ``following``, ``region``), so an error
in a production rule cannot hide in both. It is the oracle of ``test_equivalence.py``: on random
inputs the production step must agree with it to 1e-9. Readability over speed.
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
from wholebody_controller.contact_safety import Safety, SafetyConfig
from wholebody_controller.contact_task import Phase
from wholebody_controller.controller import KinematicsModel
from wholebody_controller.following import FOLD_ANGLE, LEASH_ANGLE, LEASH_DISTANCE
from wholebody_controller.qp import QPProblem, QPSolver, make_solver

Array = NDArray[np.float64]


def ref_velocity_bounds(q: Array, position_lower: Array, position_upper: Array,
                        velocity_lower: Array, velocity_upper: Array,
                        horizon: float) -> tuple[Array, Array]:
    """(22) clipped into the velocity box."""
    with np.errstate(invalid="ignore"):
        lower = np.clip((position_lower - q) / horizon, velocity_lower, velocity_upper)
        upper = np.clip((position_upper - q) / horizon, velocity_lower, velocity_upper)
    return lower, upper


def ref_build_qp(jacobian: Array, target: Array, weights: list[float], epsilon: float,
                 lower: Array, upper: Array) -> QPProblem:
    """(23): H = 2(Σ ψ_i J_iᵀ J_i + ε I), g = −2 Σ ψ_i J_iᵀ b_i, one weight per 6 rows."""
    psi = np.repeat(np.asarray(weights, dtype=np.float64), 6)
    hessian = 2.0 * (jacobian.T @ (psi[:, None] * jacobian)) + 2.0 * epsilon * np.eye(
        jacobian.shape[1])
    gradient = -2.0 * jacobian.T @ (psi * target)
    return QPProblem(hessian, gradient, lower, upper)


class RefAdmittance:
    """s⁺ = Φ s + Γ w' with full matrices, w' the wrench with its torque gated by the contact
    force (T1), then through the dead zone (D1)."""

    def __init__(self, config: LinkTaskConfig, dt: float, bands: tuple[float, float],
                 turn_limit: float = 0.0) -> None:
        g = config.admittance
        self.phi, self.gamma = discretise(diag6(g.inertia), diag6(g.damping),
                                          diag6(g.stiffness), dt)
        self.state = np.zeros(12)
        self.bands = bands
        self.turn_limit = turn_limit

    def step(self, wrench: Array, force: float = 0.0) -> None:
        """``force``: ‖f‖ of the contact [N] (0 untouched)."""
        limit = self.turn_limit
        if limit > 0.0 and force > limit:
            gate = float(np.clip((1.5 * limit - force) / (0.5 * limit), 0.0, 1.0))
            wrench = np.concatenate([wrench[:3], gate * wrench[3:]])
        parts = []
        for part, band in zip((wrench[:3], wrench[3:]), self.bands, strict=True):
            size = float(np.linalg.norm(part))
            parts.append(part * max(0.0, size - band) / size if size > 0.0 else part)
        self.state = self.phi @ self.state + self.gamma @ np.concatenate(parts)


class RefGuard:
    """Graded response to ‖f‖: fade from a·F to F, yield at F until ‖f‖ < r·F."""

    def __init__(self, limit: float, safety: SafetyConfig) -> None:
        self.limit, self.safety = limit, safety
        self.yielding = False
        self.excess = 0.0
        """σ: (‖f‖ − F) / (e·F) within [0, 1] while yielding, else 0."""
        self.opened = 0.0
        """The bounds' opening: the largest σ of the yield, until ‖f‖ ≤ a·F."""

    def update(self, force: float) -> float:
        """The approach scale s of this cycle's force [N]."""
        threshold = self.safety.reset_ratio * self.limit if self.yielding else self.limit
        self.yielding = force >= threshold
        self.excess = 0.0
        if self.yielding:
            self.excess = float(np.clip((force - self.limit)
                                        / (self.safety.full_excess * self.limit), 0.0, 1.0))
            self.opened = max(self.opened, self.excess)
            return 0.0
        if force <= self.safety.fade_start * self.limit:
            self.opened = 0.0
        start = self.safety.fade_start * self.limit
        return 1.0 if force <= start else float(np.clip((self.limit - force)
                                                         / (self.limit - start), 0.0, 1.0))


class RefRegain:
    """A desired force may act without contact for regain_distance of travel and regain_time."""

    def __init__(self, safety: SafetyConfig) -> None:
        self.safety = safety
        self.travel, self.periods, self.exhausted = 0.0, 0, False

    def update(self, in_contact: bool, travel: float, dt: float) -> bool:
        if in_contact:
            self.travel, self.periods, self.exhausted = 0.0, 0, False
            return True
        self.travel += travel
        self.periods += 1
        if (self.travel > self.safety.regain_distance
                or self.periods * dt > self.safety.regain_time + 1e-9):
            self.exhausted = True
        return not self.exhausted


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
    safety: Safety
    excess: float = 0.0
    """How far the yield opens the bounds (the largest σ, until ‖f‖ ≤ a·F)."""


class RefRegion:
    """Ω_d: locked at onset (Ω_i + margin, or the user's), grown over the onset window, and the
    track force (11) with each face behind a Schmitt trigger of width h."""

    def __init__(self, link: LinkTaskConfig, cc: ControllerConfig) -> None:
        self.user = link.desired_region
        self.margin, self.window, self.h, self.dt = (cc.region_margin, cc.region_window,
                                                     cc.region_hysteresis, cc.dt)
        self.reset()

    def reset(self) -> None:
        self.lo: Array | None = None
        self.hi: Array | None = None
        self.periods = 0
        self.engaged = np.zeros((2, 3), dtype=bool)  # [+faces, −faces] × xyz

    def update(self, lo: Array, hi: Array) -> None:
        if self.lo is None:
            self.periods = 0
            if self.user is not None:
                self.lo, self.hi = np.array(self.user[0], float), np.array(self.user[1], float)
            else:
                self.lo, self.hi = lo - self.margin, hi + self.margin
        elif self.user is None and self.periods * self.dt < self.window - 1e-12:
            assert self.hi is not None
            self.lo, self.hi = np.minimum(self.lo, lo - self.margin), \
                np.maximum(self.hi, hi + self.margin)
        self.periods += 1

    def mu(self, lo: Array, hi: Array) -> Array:
        if self.lo is None or self.hi is None:
            return np.zeros(3)
        past = np.array([hi - self.hi, self.lo - lo])  # beyond the + and the − faces
        if self.h == 0.0:
            on = past > 0.0
        else:
            self.engaged = np.where(past <= 0.0, False, np.where(past > self.h, True,
                                                                 self.engaged))
            on = self.engaged
        return np.where(on[0], past[0], 0.0) - np.where(on[1], past[1], 0.0)


class RefTask:
    """One link: contact safety, Algorithm 1, Ω_d, (10)–(20), lead moment and leash, the
    admittance's dead zone."""

    def __init__(self, config: LinkTaskConfig, cc: ControllerConfig) -> None:
        self.config, self.safety = config, cc.safety
        self.k_eta, self.b, self.k_p, self.psi_thr = cc.k_eta, cc.b, cc.k_p, cc.psi_thr
        self.dt, self.lead = cc.dt, cc.lead_moment
        self.carry = cc.lead_moment and not any(config.admittance.stiffness[3:6])
        self.carry_pos = cc.lead_moment and not any(config.admittance.stiffness[0:3])
        assert config.force_limit is not None
        self.guard = RefGuard(config.force_limit, cc.safety)
        self.regain = RefRegain(cc.safety)
        self.region = RefRegion(config, cc)
        self.adm = RefAdmittance(config, cc.dt, (cc.force_deadband, cc.torque_deadband),
                                 cc.turn_force_limit)
        self.psi_prev = 0.0
        self.point = np.zeros(3)
        self.had_contact = False
        self.last_pos: Array | None = None
        self.ref_rot: Array | None = None
        self.ref_pos: Array | None = None

    def forget(self) -> None:
        """Admittance at rest and Algorithm 1 inactive (nothing locked)."""
        self.adm.state = np.zeros(12)
        self.psi_prev = 0.0
        self.ref_rot = self.ref_pos = None

    def contact_safety(self, contact: ContactState, pos: Array) -> tuple[float, float]:
        """(approach scale, desired-force scale) of this cycle."""
        force = np.linalg.norm(contact.force) if contact.in_contact else 0.0
        was_yielding = self.guard.yielding
        scale = self.guard.update(float(force))
        if was_yielding and not self.guard.yielding:
            self.forget()
        gate = True
        if any(self.config.desired_force):
            travel = 0.0 if self.last_pos is None else float(np.linalg.norm(pos - self.last_pos))
            self.last_pos = pos.copy()
            gate = self.regain.update(bool(contact.in_contact), travel, self.dt)
        return scale, scale if gate else 0.0

    def wrench_of(self, contact: ContactState, rot: Array, yaw: float,
                  desired_scale: float) -> tuple[Array, Array]:
        """(12) plus the scaled desired force, and ⁰μ (world) [m]."""
        wrench, mu = np.zeros(6), np.zeros(3)
        if contact.in_contact:
            force = np.asarray(contact.force, dtype=np.float64)
            mu_local = self.region.mu(contact.region_min, contact.region_max)
            torque = np.asarray(contact.torque, dtype=np.float64)
            if self.lead:
                middle = 0.5 * (contact.region_min + contact.region_max)
                torque = torque + np.cross(self.point - middle, force)
            mu = rot @ mu_local
            wrench[0:3] = rot @ (force + self.k_eta * mu_local)
            wrench[3:6] = rot @ torque
        if desired_scale > 0.0 and any(self.config.desired_force):
            c, s = math.cos(yaw), math.sin(yaw)
            wrench[0:3] += desired_scale * (np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
                                            @ np.asarray(self.config.desired_force, float))
        return wrench, mu

    def leash(self, rot: Array, pos: Array) -> None:
        """Carry the reference: the rotation (F2) where K_ω = 0, then the position (F3) where
        K_p-stiffness = 0."""
        if self.carry:
            self.leash_rotation(rot)
        if self.carry_pos:
            self.leash_position(rot, pos)

    def leash_position(self, rot: Array, pos: Array) -> None:
        """Re-base p_r when the desired contact point leads the link's by more than ε_p."""
        assert self.ref_rot is not None and self.ref_pos is not None
        rot_d = exp_rotvec(self.adm.state[3:6]) @ self.ref_rot
        desired = self.ref_pos + self.adm.state[0:3] + rot_d @ self.point
        e = desired - (pos + rot @ self.point)
        if np.linalg.norm(e) <= LEASH_DISTANCE:
            return
        self.ref_pos = pos + rot @ self.point - rot_d @ self.point \
            + LEASH_DISTANCE * e / np.linalg.norm(e)
        self.adm.state[0:3] = 0.0

    def leash_rotation(self, rot: Array) -> None:
        """Re-base when R_d leads R_i by more than the leash, fold the deflection into it when
        it passes the fold angle."""
        assert self.ref_rot is not None
        x_w, v_w = self.adm.state[3:6].copy(), self.adm.state[9:12].copy()
        desired = exp_rotvec(x_w) @ self.ref_rot
        e = log_rotation(desired @ rot.T)
        if np.linalg.norm(e) > LEASH_ANGLE:
            self.ref_rot = exp_rotvec(LEASH_ANGLE * e / np.linalg.norm(e)) @ rot
        elif np.linalg.norm(x_w) > FOLD_ANGLE:
            self.ref_rot = desired
        else:
            return
        self.adm.state[9:12] = world_angular_velocity(x_w, v_w)
        self.adm.state[3:6] = 0.0

    def velocities(self, rot: Array, pos: Array, rate: Array | None) -> tuple[Array, Array]:
        """(14), (16)–(20): the QP target and the control velocity."""
        assert self.ref_rot is not None and self.ref_pos is not None
        defl, dv = self.adm.state[0:6], self.adm.state[6:12]
        rot_d = exp_rotvec(defl[3:6]) @ self.ref_rot
        omega_d = world_angular_velocity(defl[3:6], dv[3:6])
        rd_p = rot_d @ self.point
        target = np.zeros(6)
        target[0:3] = (self.k_p * (self.ref_pos + defl[0:3] - pos + rd_p - rot @ self.point)
                       + dv[0:3] + np.cross(omega_d, rd_p))
        target[3:6] = self.k_p * log_rotation(rot_d @ rot.T) + omega_d
        control = target.copy()
        if rate is not None:
            control[0:3] += rot_d @ rate
            target[0:3] += rot_d @ rate - rot @ rate
        return target, control

    def respond(self, contact: ContactState, rot: Array, scale: float, target: Array,
                control: Array) -> tuple[Array, Array]:
        """Yield along n̂ at the yield speed, or keep only s of the approach along −n̂."""
        force = np.asarray(contact.force, dtype=np.float64)
        if not contact.in_contact or np.linalg.norm(force) == 0.0:
            return target, control
        n = rot @ (force / np.linalg.norm(force))
        if self.guard.yielding:
            low = self.safety.yield_speed
            speed = low + self.guard.excess * max(self.safety.yield_speed_max - low, 0.0)
            away = np.concatenate([speed * n, np.zeros(3)])
            return away, away.copy()
        out = []
        for v in (target, control):
            v = v.copy()
            v[0:3] -= (1.0 - scale) * min(float(v[0:3] @ n), 0.0) * n
            out.append(v)
        return out[0], out[1]

    def update(self, contact: ContactState, rot: Array, pos: Array, yaw: float) -> RefOutput:
        in_contact = bool(contact.in_contact)
        scale, desired_scale = self.contact_safety(contact, pos)
        rate = None
        if in_contact:
            center = np.asarray(contact.center, dtype=np.float64)
            if self.had_contact:
                rate = (center - self.point) / self.dt
            self.point = center
        elif self.had_contact:
            self.region.reset()
        self.had_contact = in_contact
        wrench, mu = self.wrench_of(contact, rot, yaw, desired_scale)

        self.adm.step(wrench, float(np.linalg.norm(contact.force)) if in_contact else 0.0)
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
            self.region.reset()
        self.psi_prev = psi_raw
        active = psi_raw >= thr and self.ref_rot is not None
        if active:
            self.leash(rot, pos)
        if active and in_contact:
            self.region.update(contact.region_min, contact.region_max)
        if not active:
            self.adm.state[0:6] = 0.0
        target, control = np.zeros(6), np.zeros(6)
        phase = Phase.INACTIVE
        if active:
            phase = Phase.ACTIVATING if activating else (
                Phase.ACTIVE if in_contact or lock is not None else Phase.DEACTIVATING)
            target, control = self.velocities(rot, pos, rate)
        if scale < 1.0:
            target, control = self.respond(contact, rot, scale, target, control)
        elif self.regain.exhausted:
            self.forget()
            target, control = np.zeros(6), np.zeros(6)
        psi = 1.0 if self.guard.yielding else (psi_raw if psi_raw > thr else thr)
        safety = (Safety.YIELDING if self.guard.yielding else Safety.FADING if scale < 1.0
                  else Safety.CONTACT_LOST if self.regain.exhausted else Safety.OK)
        return RefOutput(phase, psi, psi_raw, self.point.copy(), target, control, wrench,
                         self.k_eta * mu, self.adm.state[0:6].copy(),
                         self.adm.state[6:12].copy(), in_contact, safety,
                         self.guard.opened)


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
        self.previous = np.zeros(len(names))
        self.vmax = np.minimum(np.minimum(np.asarray(kin.velocity_limits, float),
                                          config.velocity_limit),
                               np.asarray(config.velocity_limits, float))
        # While a link yields: the arm joints' ranges opened by yield_joint_range within their
        # own limits, the actuators' velocity (no Table II bound), the yield acceleration.
        opened = config.safety.yield_joint_range
        self.yield_lower, self.yield_upper = self.lower.copy(), self.upper.copy()
        self.yield_lower[3:] = np.maximum(limits[3:, 0], self.lower[3:] - opened)
        self.yield_upper[3:] = np.minimum(limits[3:, 1], self.upper[3:] + opened)
        self.yield_vmax = np.maximum(np.minimum(np.asarray(kin.velocity_limits, float),
                                                np.asarray(config.velocity_limits, float)),
                                     self.vmax)
        self.yield_vmax[:3] = self.vmax[:3]  # the base keeps its bounds (docs: the arm yields)

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
        # The yield opens every bound by the largest excess scale σ of the links.
        sigma = max((o.excess for o in outs), default=0.0)

        def towards(normal: Array, opened: Array) -> Array:
            with np.errstate(invalid="ignore"):
                return np.where(normal == opened, normal, normal + sigma * (opened - normal))

        vmax = towards(self.vmax, self.yield_vmax)
        lo, hi = ref_velocity_bounds(q, towards(self.lower, self.yield_lower),
                                     towards(self.upper, self.yield_upper), -vmax, vmax,
                                     self.config.horizon)
        # The actuators' rated acceleration: within a·dt of the previous command, yield or not.
        change = np.asarray(self.config.acceleration_limits, float) * self.config.dt
        lo = np.clip(lo, self.previous - change, self.previous + change)
        hi = np.clip(hi, self.previous - change, self.previous + change)
        target = np.concatenate([o.target for o in outs])
        problem = ref_build_qp(stacked, target, [o.psi for o in outs], self.config.epsilon,
                               lo, hi)
        command = self.solver.solve(problem)
        self.previous = command.copy()
        residual = target - stacked @ command
        qdot = command.copy()
        qdot[0] = c * command[0] - s * command[1]
        qdot[1] = s * command[0] + c * command[1]
        return RefStep(command, qdot, outs, [residual[6 * i: 6 * i + 6] for i in range(len(outs))],
                       problem)
