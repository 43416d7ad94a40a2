"""One contact centre's interaction task: (8), (10)–(20) and Algorithm 1 (pure).

Frames. Contact states arrive in the link frame γ_i (DH frame): centre ᶦp_η, force ᶦf_η (on the
link), torque ᶦτ_η and the contact region Ω_i. Everything the admittance and the QP use is in the
world frame 0, obtained with the link pose (⁰R_i, ⁰p_γi).

Desired region. The paper writes the track force as ⁰μ but builds Ω_i from taxel positions, which
are link-frame coordinates (III-A). We keep both Ω_i and Ω_d in the link frame — so Ω_d is a patch
of skin, locked at onset, and a robot motion without sliding never creates a track force — evaluate
(11) there, and rotate the result to the world with ⁰R_i before (12).

Speed. Each function below is one equation group on plain Python floats (rotations as row-major
9-tuples, :mod:`~wholebody_controller.linalg3`): a numpy call per operation would cost ten times
more at this size. ``test/wbc_reference.py`` is an independent numpy/scipy version of the same
equations, the oracle of ``test_equivalence.py``.
"""

from __future__ import annotations

import enum
import math
from collections.abc import Sequence
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from phri_common.planar import base_to_world
from phri_common.records import ContactState
from wholebody_controller.admittance import Admittance
from wholebody_controller.config import LinkTaskConfig, diag6
from wholebody_controller.contact_safety import (
    ForceGuard,
    RegainBudget,
    Safety,
    SafetyConfig,
    limit_approach,
)
from wholebody_controller.following import lead_moment, leash_reference
from wholebody_controller.linalg3 import matmul, matmul_transpose, rotate, rotate_pair
from wholebody_controller.region import DesiredRegion
from wholebody_controller.region import track_force as track_force  # (10)–(11), re-exported
from wholebody_controller.so3 import Mat9, Vec3, exp_and_left_jacobian, log

Array = NDArray[np.float64]

#: Layout of the 36 floats of :attr:`TaskOutput.values`.
TARGET, CONTROL, WRENCH = slice(0, 6), slice(6, 12), slice(12, 18)
DEFLECTION, DEFLECTION_VELOCITY = slice(18, 24), slice(24, 30)
POINT, TRACK_FORCE = slice(30, 33), slice(33, 36)
N_VALUES = 36
_ZERO3: Vec3 = (0.0, 0.0, 0.0)


class Phase(enum.IntEnum):
    """Life-cycle of a link's interaction (Fig. 5)."""

    INACTIVE = 0
    """ψ < ψ_thr: the task holds the link where it is, with weight ψ_thr."""
    ACTIVATING = 1
    """The step ψ first exceeds ψ_thr: reference and Ω_d are locked."""
    ACTIVE = 2
    """ψ ≥ ψ_thr while in contact (or with a locked priority)."""
    DEACTIVATING = 3
    """ψ ≥ ψ_thr after contact is lost: the admittance decays through its damping."""


# -- the equations, one function per group ------------------------------------------------------

def contact_rate(center: Vec3, previous: Vec3, dt: float) -> Vec3:
    """ᶦṗ_η [m/s]: the contact centre's rate on the link, a difference over one period (fn. 2)."""
    return ((center[0] - previous[0]) / dt, (center[1] - previous[1]) / dt,
            (center[2] - previous[2]) / dt)


def contact_wrench(force: Vec3, torque: Vec3, mu: Vec3, k_eta: float, rot: Mat9) -> list[float]:
    """⁰w_η (12) [N, N·m]: ``[⁰R_i (ᶦf_η + k_η ᶦμ); ⁰R_i ᶦτ_η]`` (link-frame inputs, world out).

    ``force`` is the estimated force on the link (9a) [N], ``torque`` the torque about the
    contact centre (9b) [N·m], ``mu`` the track force (11) [m] in the link frame, ``k_eta`` [N/m].
    """
    pushed = (force[0] + k_eta * mu[0], force[1] + k_eta * mu[1], force[2] + k_eta * mu[2])
    return list(rotate_pair(rot, pushed, torque))


def priority(deflection_velocity: Sequence[float], b: float) -> float:
    """ψ (15) = (1 − e^{−b‖ẋ̃‖²}) / (1 + e^{−b‖ẋ̃‖²}) = tanh(b‖ẋ̃‖²/2) ∈ [0, 1).

    ``deflection_velocity`` is ẋ̃ [m/s, rad/s] (6 floats), ``b`` [s²/m²].
    """
    v0, v1, v2, v3, v4, v5 = deflection_velocity
    return math.tanh(0.5 * b * (v0 * v0 + v1 * v1 + v2 * v2 + v3 * v3 + v4 * v4 + v5 * v5))


def desired_orientation(ref_rot: Mat9, rotation_deflection: Vec3,
                        rotation_deflection_rate: Vec3) -> tuple[tuple[float, ...], Vec3]:
    """(14) for the rotation: ``⁰R_d = exp([x̃_ω]×) ⁰R_r`` and its angular velocity
    ``⁰ω_d = J_l(x̃_ω) ẋ̃_ω`` [rad/s] (x_r is locked, so only the deflection moves R_d)."""
    exp_d, jac_l = exp_and_left_jacobian(rotation_deflection)
    return matmul(exp_d, ref_rot), rotate(jac_l, rotation_deflection_rate)


def task_velocity(
    rot: Mat9, pos: Vec3, point: Vec3, ref_pos: Vec3, rot_d: Mat9, omega_d: Vec3,
    deflection: Sequence[float], deflection_velocity: Sequence[float], k_p: float,
) -> tuple[Vec3, Vec3]:
    """(19)+(20) without the sliding term: the commanded velocity of the contact centre.

    ``⁰p_dγ = ⁰p_r + x̃_p`` and ``⁰ṗ_dγ = ẋ̃_p`` (14), (16); then
    linear ``K_p (⁰p_dγ − ⁰p_γ + ⁰R_d ᶦp_η − ⁰R_i ᶦp_η) + ẋ̃_p + ⁰ω_d × ⁰R_d ᶦp_η`` [m/s],
    angular ``K_p log(⁰R_d ⁰R_iᵀ)^∨ + ⁰ω_d`` [rad/s]. ``k_p`` [1/s].
    """
    qx, qy, qz = rotate(rot_d, point)
    sx, sy, sz = rotate(rot, point)
    ox, oy, oz = omega_d
    wx, wy, wz = oy * qz - oz * qy, oz * qx - ox * qz, ox * qy - oy * qx  # ω_d × R_d p
    dx, dy, dz = deflection[0], deflection[1], deflection[2]
    vx, vy, vz = deflection_velocity[0], deflection_velocity[1], deflection_velocity[2]
    linear = (k_p * ((ref_pos[0] + dx - pos[0]) + qx - sx) + vx + wx,
              k_p * ((ref_pos[1] + dy - pos[1]) + qy - sy) + vy + wy,
              k_p * ((ref_pos[2] + dz - pos[2]) + qz - sz) + vz + wz)
    ex, ey, ez = log(matmul_transpose(rot_d, rot))
    angular = (k_p * ex + omega_d[0], k_p * ey + omega_d[1], k_p * ez + omega_d[2])
    return linear, angular


def sliding_terms(rot_d: Mat9, rot: Mat9, rate: Vec3) -> tuple[Vec3, Vec3]:
    """``(⁰R_d ᶦṗ_η, ⁰R_i ᶦṗ_η)`` [m/s]: the sliding term of the desired velocity (17), (20)
    and the one of the contact-centre velocity (8), which the QP target leaves out."""
    return rotate(rot_d, rate), rotate(rot, rate)


# -- Algorithm 1 --------------------------------------------------------------------------------

class LifeCycle:
    """Algorithm 1's state of one link: activation by ψ against ψ_thr and the locked reference.

    ``ψ`` rising above ψ_thr activates the task and locks the reference pose x_r of the link
    frame (the user's reference if one is configured, else the current pose); ψ falling below
    ψ_thr deactivates it (the caller then resets the admittance, line 10).
    """

    def __init__(self, psi_thr: float, user_reference: tuple[Mat9, Vec3] | None) -> None:
        self.psi_thr = psi_thr
        self._user_reference = user_reference
        self.reset()

    @property
    def user_reference(self) -> tuple[Mat9, Vec3] | None:
        """The user's reference pose (⁰R_r row-major, ⁰p_r [m]) locked at activation, if any."""
        return self._user_reference

    def reset(self) -> None:
        """Inactive, nothing locked."""
        self.psi_prev = 0.0
        self.reference: tuple[Mat9, Vec3] | None = None
        """Locked (⁰R_r row-major, ⁰p_r [m]) while active."""

    def advance(self, psi_raw: float, rot: Mat9, pos: Vec3) -> tuple[bool, bool, bool]:
        """Take this step's ψ; returns ``(activating, deactivated, active)`` (lines 3–10), active
        = ψ ≥ ψ_thr with a locked reference (a NaN ψ is never active)."""
        thr = self.psi_thr
        activating = self.psi_prev <= thr < psi_raw
        deactivated = self.psi_prev >= thr > psi_raw
        if activating:
            self.reference = self._user_reference or (rot, pos)
        if deactivated:
            self.reference = None
        self.psi_prev = psi_raw
        return activating, deactivated, psi_raw >= thr and self.reference is not None


class TaskOutput(NamedTuple):
    """What one task contributes to the QP, plus its state for plots (world frame). Immutable.

    ``values`` holds the step's 36 floats, laid out by the slices ``TARGET`` … ``TRACK_FORCE`` of
    this module; the array properties read them:

    * ``target`` b_i [m/s, rad/s] with ``J_η q̇ ≈ b_i``: (20) minus the sliding term of (8);
    * ``control_velocity`` ⁰ẋ_cη of (20) [m/s, rad/s];
    * ``wrench`` ⁰w_η (12) [N, N·m], desired force included;
    * ``deflection`` x̃ (14) [m, rad], ``deflection_velocity`` ẋ̃ [m/s, rad/s];
    * ``point`` the contact centre ᶦp_η in the link frame [m] (the Jacobian point);
    * ``track_force`` k_η ⁰μ_η [N].
    """

    link: str
    phase: Phase
    psi: float
    """Weight ψ_i of (23): ψ of (15) (or the lock) floored at ψ_thr; a NaN ψ gives ψ_thr."""
    psi_raw: float
    """ψ_i of (15), or the locked value."""
    in_contact: bool
    values: tuple[float, ...]
    safety: Safety = Safety.OK
    """Contact-safety state of the link (:mod:`~wholebody_controller.contact_safety`)."""

    @property
    def target(self) -> Array:
        return np.array(self.values[TARGET])

    @property
    def control_velocity(self) -> Array:
        return np.array(self.values[CONTROL])

    @property
    def wrench(self) -> Array:
        return np.array(self.values[WRENCH])

    @property
    def deflection(self) -> Array:
        return np.array(self.values[DEFLECTION])

    @property
    def deflection_velocity(self) -> Array:
        return np.array(self.values[DEFLECTION_VELOCITY])

    @property
    def point(self) -> Array:
        return np.array(self.values[POINT])

    @property
    def track_force(self) -> Array:
        return np.array(self.values[TRACK_FORCE])


class ContactTask:
    """One skin link's interaction task: its admittance, Algorithm 1 and Ω_d, stepped per cycle."""

    def __init__(self, config: LinkTaskConfig, *, k_eta: float, b: float, k_p: float,
                 psi_thr: float, region_margin: float, dt: float,
                 safety: SafetyConfig | None = None, region_window: float = 0.0,
                 region_hysteresis: float = 0.0, lead: bool = False) -> None:
        self.config = config
        self.lead = lead
        """Add the lead moment (F1) about the region's middle and carry the reference (F2)
        (:mod:`~wholebody_controller.following`)."""
        self.safety = safety or SafetyConfig()
        assert config.force_limit is not None and config.transient_force_limit is not None
        self.guard = ForceGuard(config.force_limit, config.transient_force_limit, self.safety)
        self.regain = RegainBudget(self.safety)
        self.k_eta, self.b, self.k_p = k_eta, b, k_p
        self.psi_thr, self.region_margin, self.dt = psi_thr, region_margin, dt
        fx, fy, fz = config.desired_force
        self.desired_force: Vec3 = (float(fx), float(fy), float(fz))
        gains = config.admittance
        self.admittance = Admittance(
            diag6(gains.inertia), diag6(gains.damping), diag6(gains.stiffness), dt
        )
        self._carry = lead and not any(gains.stiffness[3:6])
        self.no_contact = ContactState.no_contact(config.link, 0)
        user = None
        if config.reference is not None:
            ref = [float(x) for x in config.reference]
            user = (tuple(ref[0:9]), (ref[9], ref[10], ref[11]))
        self.life_cycle = LifeCycle(psi_thr, user)
        box = None
        if config.desired_region is not None:
            (a, b, c), (d, e, f) = config.desired_region
            box = ((float(a), float(b), float(c)), (float(d), float(e), float(f)))
        self.region = DesiredRegion(region_margin, region_window, region_hysteresis, dt, box)
        self.reset()

    @property
    def carries_reference(self) -> bool:
        """Whether the reference is carried on the leash (F2): lead moment on, K_ω = 0."""
        return self._carry

    def reset(self) -> None:
        """Back to inactive: admittance zero, nothing locked."""
        self.admittance.reset()
        self.life_cycle.reset()
        self.guard.reset()
        self.regain.reset()
        self._last_pos: Vec3 | None = None
        self._point: Vec3 = _ZERO3
        self.jacobian_point: Array = np.zeros(3)
        """ᶦp_η as an array for the Jacobian (8); the last touched centre is held after release,
        so the task point does not jump while the admittance decays."""
        self._had_contact = False
        self.region.reset()

    @property
    def locked_reference(self) -> tuple[Array, Array] | None:
        """The reference pose (⁰R_r 3×3, ⁰p_r [m]) of the link frame, while active."""
        ref = self.life_cycle.reference
        return None if ref is None else (np.array(ref[0]).reshape(3, 3), np.array(ref[1]))

    @property
    def desired_region(self) -> tuple[Array, Array] | None:
        """Ω_d (link frame, margin included) [m] while locked."""
        box = self.region.box
        return None if box is None else (np.array(box[0]), np.array(box[1]))

    def _track_contact(self, contact: ContactState) -> Vec3 | None:
        """Update ᶦp_η from a touched contact; returns ᶦṗ_η between two touched samples."""
        rate = None
        if contact.in_contact:
            cx, cy, cz = contact.center.tolist()
            if self._had_contact:
                rate = contact_rate((cx, cy, cz), self._point, self.dt)
            self._point = (cx, cy, cz)
            self.jacobian_point = contact.center
        elif self._had_contact:
            self.region.reset()  # Ω_d belonged to that touch; a new touch locks its own
        self._had_contact = bool(contact.in_contact)
        return rate

    def _wrench(self, contact: ContactState, force: Vec3 | None, rot: Mat9, base_yaw: float,
                desired_scale: float) -> tuple[list[float], Vec3]:
        """(10)–(12) plus ``desired_scale`` times the manual desired force (base frame → world,
        gated and faded by :mod:`contact_safety`); also ᶦμ [m]."""
        mu: Vec3 = _ZERO3
        wrench = [0.0] * 6
        if force is not None:
            if self.region.box is not None:
                lo, hi = contact.region_min.tolist(), contact.region_max.tolist()
                mu = self.region.track_force(lo, hi)
                if mu == _ZERO3:
                    mu = _ZERO3  # the shared zero: no rotation needed downstream
            torque = contact.torque.tolist()
            if self.lead:
                tx, ty, tz = lead_moment(self._point, contact.region_min.tolist(),
                                         contact.region_max.tolist(), force)
                torque = [torque[0] + tx, torque[1] + ty, torque[2] + tz]
            wrench = contact_wrench(force, torque, mu, self.k_eta, rot)
        fx, fy, fz = self.desired_force
        if desired_scale > 0.0 and (fx != 0.0 or fy != 0.0 or fz != 0.0):
            fx, fy, fz = desired_scale * fx, desired_scale * fy, desired_scale * fz
            dx, dy = base_to_world(base_yaw, fx, fy)
            wrench[0] += dx
            wrench[1] += dy
            wrench[2] += fz
        return wrench, mu

    def _velocities(self, rot: Mat9, pos: Vec3, rate: Vec3 | None) -> tuple[float, ...]:
        """(14), (16)–(20) and (8) while active: ``target`` and ``control`` (12 floats)."""
        reference = self.life_cycle.reference
        assert reference is not None
        ref_rot, ref_pos = reference
        x, v = self.admittance.state_f
        rot_d, omega_d = desired_orientation(ref_rot, (x[3], x[4], x[5]), (v[3], v[4], v[5]))
        (lx, ly, lz), angular = task_velocity(rot, pos, self._point, ref_pos, rot_d, omega_d,
                                              x, v, self.k_p)
        if rate is None:
            return (lx, ly, lz, *angular, lx, ly, lz, *angular)
        (dx, dy, dz), (sx, sy, sz) = sliding_terms(rot_d, rot, rate)
        return (lx + (dx - sx), ly + (dy - sy), lz + (dz - sz), *angular,
                lx + dx, ly + dy, lz + dz, *angular)

    def _carry_reference(self, rot: Mat9) -> None:
        """(F2): re-base the locked reference when the desired orientation leads the link's
        ``rot`` by more than the leash."""
        reference = self.life_cycle.reference
        if reference is None:
            return
        x, v = self.admittance.state_f
        carried = leash_reference(reference[0], (x[3], x[4], x[5]), (v[3], v[4], v[5]), rot)
        if carried is not None:
            self.life_cycle.reference = (carried[0], reference[1])
            self.admittance.set_rotation((0.0, 0.0, 0.0), carried[1])

    def _safety(self, force: Vec3 | None, in_contact: bool,
                pos: Vec3) -> tuple[float, float, Vec3 | None]:
        """This cycle's contact safety (:mod:`contact_safety`) from the contact force on the link
        ``force`` [N] (link frame, ``None`` untouched): ``(approach scale s, desired-force scale,
        n̂ in the link frame or None)``; updates the force guard and the regain budget."""
        normal = None
        magnitude = 0.0
        if force is not None:
            fx, fy, fz = force
            magnitude = math.sqrt(fx * fx + fy * fy + fz * fz)
            if magnitude > 0.0:
                normal = (fx / magnitude, fy / magnitude, fz / magnitude)
        was_yielding = self.guard.yielding
        scale = self.guard.update(magnitude)
        if was_yielding and not self.guard.yielding:
            self.admittance.reset()  # the yield is over: a fresh start, no stored push
            self.life_cycle.reset()
        gate = True
        if self.desired_force != _ZERO3:  # only a manual desired force is gated
            last, self._last_pos = self._last_pos, pos
            travel = 0.0 if last is None else math.dist(pos, last)
            gate = self.regain.update(in_contact, travel, self.dt)
        return scale, scale if gate else 0.0, normal

    def _safety_state(self, scale: float) -> Safety:
        if self.guard.yielding:
            return Safety.YIELDING
        if scale < 1.0:
            return Safety.FADING
        if self.regain.exhausted and self.desired_force != _ZERO3:
            return Safety.CONTACT_LOST
        return Safety.OK

    def _guarded(self, velocities: tuple[float, ...], rot: Mat9, normal: Vec3 | None,
                 scale: float) -> tuple[float, ...]:
        """Target and control velocities after the graded response: while yielding, the contact
        centre moves along n̂ at the yield speed; while fading, motion towards the contact is
        scaled by s (:func:`limit_approach`)."""
        if normal is None:
            return velocities
        n = rotate(rot, normal)
        if self.guard.yielding:
            v = self.safety.yield_speed
            away = (v * n[0], v * n[1], v * n[2], 0.0, 0.0, 0.0)
            return away + away
        target = limit_approach((velocities[0], velocities[1], velocities[2]), n, scale)
        control = limit_approach((velocities[6], velocities[7], velocities[8]), n, scale)
        return (*target, *velocities[3:6], *control, *velocities[9:12])

    def step(self, contact: ContactState, rot: Mat9, pos: Vec3, base_yaw: float) -> TaskOutput:
        """One control step of this link (Algorithm 1 around (8), (10)–(20), then the contact
        safety of :mod:`contact_safety`).

        Args:
            contact: the link's latest contact state (link frame).
            rot: ⁰R_i, the link frame's rotation in the world, row-major.
            pos: ⁰p_γi, the link frame's origin in the world [m].
            base_yaw: base heading [rad] (turns the base-frame desired force into the world).
        """
        in_contact = bool(contact.in_contact)
        force: Vec3 | None = contact.force.tolist() if in_contact else None
        scale, desired_scale, normal = self._safety(force, in_contact, pos)
        rate = self._track_contact(contact)
        wrench, mu = self._wrench(contact, force, rot, base_yaw, desired_scale)
        adm = self.admittance
        adm.step_f(wrench)  # (13)
        lock = self.config.priority_lock
        psi_raw = lock if lock is not None else priority(adm.state_f[1], self.b)
        activating, deactivated, active = self.life_cycle.advance(psi_raw, rot, pos)
        if deactivated:
            adm.reset()  # line 10
            self.region.reset()
        if active and self._carry:
            self._carry_reference(rot)
        if active and contact.in_contact:  # line 14 (and the onset window, :mod:`region`)
            self.region.update(contact.region_min.tolist(), contact.region_max.tolist())
        if active:
            phase = _ACTIVATING if activating else (
                _ACTIVE if contact.in_contact or lock is not None else _DEACTIVATING)
            velocities = self._velocities(rot, pos, rate)
        else:
            adm.zero_deflection()  # lines 7/10: x_d = x_r = x_γ, so x̃ = 0 by (14)
            phase, velocities = _INACTIVE, _ZERO12
        if scale < 1.0:
            velocities = self._guarded(velocities, rot, normal, scale)
        elif self.regain.exhausted:
            # Contact lost past the regain budget: this link stops and waits for a touch (no
            # pull back to the old reference either); a new touch re-activates the task afresh.
            adm.reset()
            self.life_cycle.reset()
            velocities = _ZERO12
        x, v = adm.state_f
        k = self.k_eta
        mx, my, mz = _ZERO3 if mu is _ZERO3 else rotate(rot, mu)
        values = (*velocities, *wrench, *x, *v, *self._point, k * mx, k * my, k * mz)
        thr = self.psi_thr
        psi = 1.0 if self.guard.yielding else (psi_raw if psi_raw > thr else thr)
        safety = _SAFE if scale == 1.0 and not self.regain.exhausted else \
            self._safety_state(scale)
        return _make_output((self.config.link, phase, psi, psi_raw, in_contact, values, safety))


_INACTIVE, _ACTIVATING, _ACTIVE, _DEACTIVATING = (
    Phase.INACTIVE, Phase.ACTIVATING, Phase.ACTIVE, Phase.DEACTIVATING
)
_ZERO12: tuple[float, ...] = (0.0,) * 12
_SAFE = Safety.OK
_make_output = TaskOutput._make  # from a tuple in field order: a third cheaper than TaskOutput(…)
