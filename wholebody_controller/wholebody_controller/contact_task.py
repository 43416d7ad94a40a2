"""One contact centre's interaction task: (10)–(21) and the life-cycle of Algorithm 1 (pure).

Frames. Contact states arrive in the link frame γ_i (DH frame): centre ᶦp_η, force ᶦf_η (on the
link), torque ᶦτ_η and the contact region Ω_i. Everything the admittance and the QP use is in the
world frame 0, obtained with the link pose (⁰R_i, ⁰p_γi).

Desired region. The paper writes the track force as ⁰μ but builds Ω_i from taxel positions, which
are link-frame coordinates (III-A). We keep both Ω_i and Ω_d in the link frame — so Ω_d is a patch
of skin, locked at onset, and a robot motion without sliding never creates a track force — evaluate
(11) there, and rotate the result to the world with ⁰R_i before (12).
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from phri_common.contact import ContactState
from wholebody_controller.admittance import Admittance
from wholebody_controller.config import LinkTaskConfig, diag6
from wholebody_controller.so3 import cross, exp_and_left_jacobian_so3, log_so3

Array = NDArray[np.float64]

_ZERO3 = np.zeros(3)
_ZERO3.flags.writeable = False


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


def relu(x: Array) -> Array:
    """f_R(x) = max(x, 0), elementwise (10)."""
    return np.maximum(x, 0.0)


def track_force(
    region_min: Array, region_max: Array, desired_min: Array, desired_max: Array
) -> Array:
    """Track force μ (11) [m] of a region against the desired region, same frame as the inputs.

    Zero while Ω_i ⊆ Ω_d; a region extending past the desired +x face gives +x (the link is pushed
    the way the contact slid, so the contact returns into Ω_d), past the −x face gives −x.
    """
    return relu(region_max - desired_max) - relu(desired_min - region_min)


def priority(deflection_velocity: Array, b: float) -> float:
    """ψ (15) = (1 − e^{−b‖ẋ̃‖²}) / (1 + e^{−b‖ẋ̃‖²}) = tanh(b‖ẋ̃‖²/2) ∈ [0, 1)."""
    return math.tanh(0.5 * b * float(deflection_velocity @ deflection_velocity))


@dataclass(frozen=True)
class TaskOutput:
    """What one task contributes to the QP, plus its state for plots (world frame).

    Attributes:
        link: link name.
        phase: life-cycle phase.
        psi: weight ψ_i used in (23) (≥ ψ_thr).
        psi_raw: ψ_i of (15) before the floor (or the locked value).
        point: contact centre in the link frame ᶦp_η [m] (the Jacobian point).
        target: desired contact-centre velocity b_i [m/s, rad/s] with ``J_η q̇ ≈ b_i``:
            (20) minus the sliding term ⁰R_i ᶦṗ_η of (8).
        control_velocity: ⁰ẋ_cη of (20) [m/s, rad/s].
        wrench: ⁰w_η (12) [N, N·m], including the desired force.
        track_force: k_η ⁰μ_η [N].
        deflection: x̃ (14) [m, rad].
        deflection_velocity: ẋ̃ [m/s, rad/s].
        in_contact: whether the link is touched.
    """

    link: str
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


class ContactTask:
    """State machine and control law of one contact centre (Algorithm 1, (10)–(20))."""

    def __init__(
        self,
        config: LinkTaskConfig,
        *,
        k_eta: float,
        b: float,
        k_p: float,
        psi_thr: float,
        region_margin: float,
        dt: float,
    ) -> None:
        self.config = config
        self.k_eta, self.b, self.k_p = k_eta, b, k_p
        self.psi_thr, self.region_margin, self.dt = psi_thr, region_margin, dt
        self._has_desired_force = any(f != 0.0 for f in config.desired_force)
        gains = config.admittance
        self.admittance = Admittance(
            diag6(gains.inertia), diag6(gains.damping), diag6(gains.stiffness), dt
        )
        self.reset()

    def reset(self) -> None:
        """Back to inactive: admittance zero, nothing locked."""
        self.admittance.reset()
        self._psi_prev = 0.0
        self._point = np.zeros(3)
        self._had_contact = False
        self._ref_rot: Array | None = None
        self._ref_pos: Array | None = None
        self._desired_min: Array | None = None
        self._desired_max: Array | None = None

    @property
    def locked_reference(self) -> tuple[Array, Array] | None:
        """The reference pose (⁰R_r, ⁰p_r) of the link frame, while active."""
        if self._ref_rot is None or self._ref_pos is None:
            return None
        return self._ref_rot, self._ref_pos

    @property
    def desired_region(self) -> tuple[Array, Array] | None:
        """Ω_d (link frame, margin included) while locked."""
        if self._desired_min is None or self._desired_max is None:
            return None
        return self._desired_min, self._desired_max

    def _lock_region(self, contact: ContactState) -> None:
        user = self.config.desired_region
        if user is not None:
            self._desired_min = np.asarray(user[0], dtype=float)
            self._desired_max = np.asarray(user[1], dtype=float)
        else:
            self._desired_min = contact.region_min - self.region_margin
            self._desired_max = contact.region_max + self.region_margin

    def update(
        self, contact: ContactState, rot: Array, pos: Array, base_yaw: float
    ) -> TaskOutput:
        """One control step of this link.

        Args:
            contact: the link's latest contact state (link frame).
            rot: ⁰R_i, the link frame's rotation in the world.
            pos: ⁰p_γi, the link frame's origin in the world [m].
            base_yaw: base heading [rad] (turns the base-frame desired force into the world).
        """
        dt = self.dt
        in_contact = bool(contact.in_contact)
        # Contact centre ᶦp_η and its rate ᶦṗ_η (footnote 2: difference over one step). The rate
        # is only taken between two touched samples, and the last centre is held after release so
        # the task point does not jump while the admittance decays.
        point_rate = _ZERO3
        if in_contact:
            center = np.asarray(contact.center, dtype=np.float64)
            if self._had_contact:
                point_rate = (center - self._point) * (1.0 / dt)
            self._point = center
        elif self._had_contact:
            # Lost contact: Ω_d belonged to that touch; a new touch locks its own.
            self._desired_min = self._desired_max = None
        self._had_contact = in_contact
        point = self._point

        # Wrench (12): force and torque rotated to the world, plus the track force (10)-(11),
        # evaluated in the link frame against a locked Ω_d (module docstring).
        mu = _ZERO3
        wrench = np.zeros(6)
        if in_contact:
            local_force = contact.force
            if self._desired_min is not None and self._desired_max is not None:
                mu_local = track_force(
                    contact.region_min, contact.region_max, self._desired_min, self._desired_max
                )
                if mu_local.any():
                    mu = rot @ mu_local
                    local_force = local_force + (self.k_eta * mu_local)
            wrench[0:3] = rot @ local_force
            wrench[3:6] = rot @ contact.torque
        if self._has_desired_force:
            # Manual desired force, base frame → world.
            c, s = math.cos(base_yaw), math.sin(base_yaw)
            fx, fy, fz = self.config.desired_force
            wrench[0] += c * fx - s * fy
            wrench[1] += s * fx + c * fy
            wrench[2] += fz

        # Admittance (13) and priority (15).
        self.admittance.step(wrench)
        lock = self.config.priority_lock
        if lock is not None:
            psi_raw = lock
        else:
            psi_raw = priority(self.admittance.deflection_velocity, self.b)

        # Algorithm 1.
        thr = self.psi_thr
        activating = self._psi_prev <= thr < psi_raw
        deactivated = self._psi_prev >= thr > psi_raw
        if activating:
            self._ref_rot, self._ref_pos = rot.copy(), pos.copy()
            if self.config.reference is not None:
                ref = np.asarray(self.config.reference, dtype=float)
                self._ref_rot, self._ref_pos = ref[:9].reshape(3, 3), ref[9:12].copy()
        if deactivated:
            self.admittance.reset()
            self._ref_rot = self._ref_pos = None
            self._desired_min = self._desired_max = None
        self._psi_prev = psi_raw
        active = psi_raw >= thr and self._ref_rot is not None
        if active and in_contact and self._desired_min is None:
            # Ω_d ← Ω_i at the onset of the touch (line 14).
            self._lock_region(contact)

        if not active:
            # Lines 7/10: x_d = x_r = x_γ, so x̃ = 0 by (14); ẋ̃ keeps integrating so ψ can rise.
            self.admittance.zero_deflection()
        deflection = self.admittance.deflection.copy()
        deflection_velocity = self.admittance.deflection_velocity.copy()

        target = np.zeros(6)
        if active:
            assert self._ref_rot is not None and self._ref_pos is not None
            phase = Phase.ACTIVATING if activating else (
                Phase.ACTIVE if in_contact or lock is not None else Phase.DEACTIVATING
            )
            k_p = self.k_p
            # Desired pose of γ_i: x_d = x_r ⊕ x̃ (14), rotation as a world-frame rotation vector;
            # ω_d = J_l(x̃_ω) ẋ̃_ω is the angular velocity of R_d.
            exp_d, jac_l = exp_and_left_jacobian_so3(deflection[3:6])
            rot_d = exp_d @ self._ref_rot
            omega_d = jac_l @ deflection_velocity[3:6]
            # (19): x_r is locked, so ẋ_dγ = ẋ̃; (20): shift to the contact centre with
            # Ṙ_d ᶦp = ω_d × R_d ᶦp. Target = (20) less the sliding term ⁰R_i ᶦṗ_η of (8).
            rd_p = rot_d @ point
            target[0:3] = (
                k_p * (self._ref_pos + deflection[0:3] - pos + rd_p - rot @ point)
                + deflection_velocity[0:3]
                + cross(omega_d, rd_p)
            )
            target[3:6] = k_p * log_so3(rot_d @ rot.T) + omega_d
            control_eta = target.copy()
            if point_rate is not _ZERO3:
                sliding_d = rot_d @ point_rate
                sliding = rot @ point_rate
                control_eta[0:3] += sliding_d
                target[0:3] += sliding_d - sliding
        else:
            # Inactive: the task only holds the link (x_d = x_γ), whatever slides on it.
            phase = Phase.INACTIVE
            control_eta = target.copy()
        return TaskOutput(
            link=self.config.link,
            phase=phase,
            psi=max(psi_raw, thr),
            psi_raw=psi_raw,
            point=point.copy(),
            target=target,
            control_velocity=control_eta,
            wrench=wrench,
            track_force=self.k_eta * mu,
            deflection=deflection,
            deflection_velocity=deflection_velocity,
            in_contact=in_contact,
        )
