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

import numpy as np
from numpy.typing import NDArray

from phri_common.records import ContactState
from wholebody_controller.admittance import Admittance
from wholebody_controller.config import LinkTaskConfig, diag6
from wholebody_controller.so3 import Mat9, log_of_product_transpose_f

Array = NDArray[np.float64]

#: Layout of the 36 floats of :attr:`TaskOutput.values` (slices into the list).
TARGET, CONTROL, WRENCH = slice(0, 6), slice(6, 12), slice(12, 18)
DEFLECTION, DEFLECTION_VELOCITY = slice(18, 24), slice(24, 30)
POINT, TRACK_FORCE = slice(30, 33), slice(33, 36)
N_VALUES = 36


def floats3(v: object) -> list[float]:
    """A 3-vector (array or sequence) as Python floats."""
    if type(v) is np.ndarray:
        out: list[float] = v.tolist()
        return out
    return [float(x) for x in v]  # type: ignore[attr-defined]


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


# Phase members as module constants: the hot path skips the enum class attribute lookup.
_INACTIVE, _ACTIVATING, _ACTIVE, _DEACTIVATING = (
    Phase.INACTIVE, Phase.ACTIVATING, Phase.ACTIVE, Phase.DEACTIVATING
)
_new_object = object.__new__


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


class TaskOutput:
    """What one task contributes to the QP, plus its state for plots (world frame).

    Read-only. The vectors are kept as the step's plain floats and each attribute access returns
    a fresh array of them: the controller makes one output per link and step, and most are never
    read in full (the node packs the floats straight into its state message, :attr:`values`).

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

    __slots__ = ("_in_contact", "_link", "_phase", "_psi", "_psi_raw", "_values")

    def __init__(
        self,
        *,
        link: str,
        phase: Phase,
        psi: float,
        psi_raw: float,
        point: Array,
        target: Array,
        control_velocity: Array,
        wrench: Array,
        track_force: Array,
        deflection: Array,
        deflection_velocity: Array,
        in_contact: bool,
    ) -> None:
        values: list[float] = []
        for vector, size in ((target, 6), (control_velocity, 6), (wrench, 6), (deflection, 6),
                             (deflection_velocity, 6), (point, 3), (track_force, 3)):
            floats = np.asarray(vector, dtype=np.float64).ravel().tolist()
            if len(floats) != size:
                raise ValueError(f"task output vector of {len(floats)} values, expected {size}")
            values += floats
        self._set(link, phase, psi, psi_raw, in_contact, values)

    def _set(self, link: str, phase: Phase, psi: float, psi_raw: float, in_contact: bool,
             values: list[float]) -> None:
        self._link, self._phase, self._psi, self._psi_raw = link, phase, psi, psi_raw
        self._in_contact, self._values = in_contact, values

    @classmethod
    def from_values(cls, link: str, phase: Phase, psi: float, psi_raw: float, in_contact: bool,
                    values: list[float]) -> TaskOutput:
        """From the 36 floats of a step (not copied: the caller hands them over)."""
        out = _new_object(cls)
        out._link, out._phase, out._psi, out._psi_raw = link, phase, psi, psi_raw
        out._in_contact, out._values = in_contact, values
        return out

    @property
    def values(self) -> tuple[float, ...]:
        """The 36 floats (layout: the slices ``TARGET`` … ``TRACK_FORCE`` of this module)."""
        return tuple(self._values)

    link = property(lambda self: self._link, doc="link name")
    phase = property(lambda self: self._phase, doc="life-cycle phase")
    psi = property(lambda self: self._psi, doc="weight ψ_i used in (23)")
    psi_raw = property(lambda self: self._psi_raw, doc="ψ_i of (15) or the lock")
    in_contact = property(lambda self: self._in_contact, doc="whether the link is touched")

    @property
    def point(self) -> Array:
        return np.array(self._values[POINT])

    @property
    def target(self) -> Array:
        return np.array(self._values[TARGET])

    @property
    def control_velocity(self) -> Array:
        return np.array(self._values[CONTROL])

    @property
    def wrench(self) -> Array:
        return np.array(self._values[WRENCH])

    @property
    def track_force(self) -> Array:
        return np.array(self._values[TRACK_FORCE])

    @property
    def deflection(self) -> Array:
        return np.array(self._values[DEFLECTION])

    @property
    def deflection_velocity(self) -> Array:
        return np.array(self._values[DEFLECTION_VELOCITY])

    def __repr__(self) -> str:
        return (f"TaskOutput(link={self._link!r}, phase={self._phase!r}, psi={self._psi!r}, "
                f"in_contact={self._in_contact!r}, target={self._values[TARGET]!r})")


class ContactTask:
    """State machine and control law of one contact centre (Algorithm 1, (10)–(20)).

    Implementation note: the per-step work is a few hundred operations on 3-vectors and 3×3
    matrices, so it is written with plain Python floats (rotations as row-major 9-tuples); a numpy
    call per operation would cost ten times more. ``test/wbc_reference.py`` keeps the
    array-per-operation version as the oracle of the equivalence tests.
    """

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
        # Copies of config fields read every step (the config never changes for a task).
        self._link = config.link
        self._desired_force = tuple(float(f) for f in config.desired_force)
        self._priority_lock = config.priority_lock
        gains = config.admittance
        self.admittance = Admittance(
            diag6(gains.inertia), diag6(gains.damping), diag6(gains.stiffness), dt
        )
        self.no_contact = ContactState.no_contact(config.link, 0)
        self._user_reference: tuple[Mat9, list[float]] | None = None
        if config.reference is not None:
            ref = [float(x) for x in config.reference]
            self._user_reference = (ref[0:9], ref[9:12])
        self.reset()

    def reset(self) -> None:
        """Back to inactive: admittance zero, nothing locked."""
        self.admittance.reset()
        self._psi_prev = 0.0
        self._point = [0.0, 0.0, 0.0]
        self.point_array: Array = np.zeros(3)
        """ᶦp_η as an array (the Jacobian point); the contact's own array while touched."""
        self._had_contact = False
        self._ref_rot: Mat9 | None = None
        self._ref_pos: list[float] | None = None
        self._desired: tuple[list[float], list[float]] | None = None

    @property
    def locked_reference(self) -> tuple[Array, Array] | None:
        """The reference pose (⁰R_r, ⁰p_r) of the link frame, while active."""
        if self._ref_rot is None or self._ref_pos is None:
            return None
        return np.array(self._ref_rot).reshape(3, 3), np.array(self._ref_pos)

    @property
    def desired_region(self) -> tuple[Array, Array] | None:
        """Ω_d (link frame, margin included) while locked."""
        if self._desired is None:
            return None
        return np.array(self._desired[0]), np.array(self._desired[1])

    def _lock_region(self, contact: ContactState) -> None:
        user = self.config.desired_region
        if user is not None:
            self._desired = ([float(x) for x in user[0]], [float(x) for x in user[1]])
        else:
            m = self.region_margin
            self._desired = (
                [x - m for x in floats3(contact.region_min)],
                [x + m for x in floats3(contact.region_max)],
            )

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
        r = np.asarray(rot, dtype=np.float64).ravel().tolist()
        out = self.advance(contact, r, floats3(pos), math.cos(base_yaw), math.sin(base_yaw))
        out._psi = max(out._psi_raw, self.psi_thr)  # as before: a NaN ψ stays NaN here
        return out

    def advance(
        self, contact: ContactState, rot: Mat9, pos: list[float], cos_yaw: float, sin_yaw: float
    ) -> TaskOutput:
        """:meth:`update` on plain floats (the controller's hot path).

        Returns the step's :class:`TaskOutput`, with ψ floored at ψ_thr (a NaN ψ gives ψ_thr,
        the weight the controller uses; :meth:`update` keeps NaN visible).

        Args:
            contact: the link's latest contact state (link frame).
            rot: ⁰R_i, row-major.
            pos: ⁰p_γi [m].
            cos_yaw, sin_yaw: of the base heading (desired force, base frame → world).
        """
        in_contact = bool(contact.in_contact)
        r0, r1, r2, r3, r4, r5, r6, r7, r8 = rot
        # Contact centre ᶦp_η and its rate ᶦṗ_η (footnote 2: difference over one step). The rate
        # is only taken between two touched samples, and the last centre is held after release so
        # the task point does not jump while the admittance decays.
        rate: list[float] | None = None
        if in_contact:
            v = contact.center
            center = v.tolist() if type(v) is np.ndarray else floats3(v)
            if self._had_contact:
                inv_dt = 1.0 / self.dt
                new_x, new_y, new_z = center
                old_x, old_y, old_z = self._point
                rate = [(new_x - old_x) * inv_dt, (new_y - old_y) * inv_dt,
                        (new_z - old_z) * inv_dt]
            self._point = center
            self.point_array = np.asarray(contact.center, dtype=np.float64)
        elif self._had_contact:
            # Lost contact: Ω_d belonged to that touch; a new touch locks its own.
            self._desired = None
        self._had_contact = in_contact
        px, py, pz = self._point

        # Wrench (12): force and torque rotated to the world, plus the track force (10)-(11),
        # evaluated in the link frame against a locked Ω_d (module docstring).
        mux = muy = muz = 0.0
        wx = wy = wz = tx = ty = tz = 0.0
        if in_contact:
            v = contact.force
            fx, fy, fz = v.tolist() if type(v) is np.ndarray else floats3(v)
            if self._desired is not None:
                (dlx, dly, dlz), (dhx, dhy, dhz) = self._desired
                v = contact.region_min
                lox, loy, loz = v.tolist() if type(v) is np.ndarray else floats3(v)
                v = contact.region_max
                hix, hiy, hiz = v.tolist() if type(v) is np.ndarray else floats3(v)
                # (10)-(11): relu(max − max_d) − relu(min_d − min), per axis (relu inlined)
                ux, uy, uz = hix - dhx, hiy - dhy, hiz - dhz
                bx, by, bz = dlx - lox, dly - loy, dlz - loz
                lx = (ux if ux > 0.0 else 0.0) - (bx if bx > 0.0 else 0.0)
                ly = (uy if uy > 0.0 else 0.0) - (by if by > 0.0 else 0.0)
                lz = (uz if uz > 0.0 else 0.0) - (bz if bz > 0.0 else 0.0)
                if lx != 0.0 or ly != 0.0 or lz != 0.0:
                    mux = r0 * lx + r1 * ly + r2 * lz
                    muy = r3 * lx + r4 * ly + r5 * lz
                    muz = r6 * lx + r7 * ly + r8 * lz
                    k = self.k_eta
                    fx, fy, fz = fx + k * lx, fy + k * ly, fz + k * lz
            wx = r0 * fx + r1 * fy + r2 * fz
            wy = r3 * fx + r4 * fy + r5 * fz
            wz = r6 * fx + r7 * fy + r8 * fz
            v = contact.torque
            cx, cy, cz = v.tolist() if type(v) is np.ndarray else floats3(v)
            tx = r0 * cx + r1 * cy + r2 * cz
            ty = r3 * cx + r4 * cy + r5 * cz
            tz = r6 * cx + r7 * cy + r8 * cz
        if self._has_desired_force:
            # Manual desired force, base frame → world.
            dfx, dfy, dfz = self._desired_force
            wx += cos_yaw * dfx - sin_yaw * dfy
            wy += sin_yaw * dfx + cos_yaw * dfy
            wz += dfz
        wrench = [wx, wy, wz, tx, ty, tz]

        # Admittance (13) and priority (15).
        adm = self.admittance
        adm.step_f(wrench)
        lock = self._priority_lock
        if lock is not None:
            psi_raw = lock
        else:
            v0, v1, v2, v3, v4, v5 = adm.state_f[1]
            norm2 = v0 * v0 + v1 * v1 + v2 * v2 + v3 * v3 + v4 * v4 + v5 * v5
            psi_raw = math.tanh(0.5 * self.b * norm2)

        # Algorithm 1.
        thr = self.psi_thr
        activating = self._psi_prev <= thr < psi_raw
        deactivated = self._psi_prev >= thr > psi_raw
        if activating:
            if self._user_reference is not None:
                self._ref_rot, self._ref_pos = self._user_reference
            else:
                self._ref_rot, self._ref_pos = rot, list(pos)
        if deactivated:
            adm.reset()
            self._ref_rot = self._ref_pos = None
            self._desired = None
        self._psi_prev = psi_raw
        ref_rot, ref_pos = self._ref_rot, self._ref_pos
        active = psi_raw >= thr and ref_rot is not None
        if active and in_contact and self._desired is None:
            # Ω_d ← Ω_i at the onset of the touch (line 14).
            self._lock_region(contact)

        if not active:
            # Lines 7/10: x_d = x_r = x_γ, so x̃ = 0 by (14); ẋ̃ keeps integrating so ψ can rise.
            adm.zero_deflection()
        deflection, deflection_velocity = adm.state_f

        if active:
            assert ref_rot is not None and ref_pos is not None
            phase = _ACTIVATING if activating else (
                _ACTIVE if in_contact or lock is not None else _DEACTIVATING
            )
            k_p = self.k_p
            dx, dy, dz, drx, dry, drz = deflection
            vx, vy, vz, vrx, vry, vrz = deflection_velocity
            # Desired pose of γ_i: x_d = x_r ⊕ x̃ (14), rotation as a world-frame rotation vector;
            # ω_d = J_l(x̃_ω) ẋ̃_ω is the angular velocity of R_d.
            # exp_and_left_jacobian_f inlined (hot path; test_equivalence covers it): both are
            # I + α[φ]× + β[φ]×², [φ]×² = φφᵀ − θ²I. At θ = 0 the small-angle coefficients give
            # exactly I, as the function's own θ = 0 branch does.
            xx, yy, zz = drx * drx, dry * dry, drz * drz
            theta2 = xx + yy + zz
            if theta2 < 1e-10:
                a, b, aj, bj = 1.0, 0.5, 0.5, 1.0 / 6.0
            else:
                theta = math.sqrt(theta2)
                sin_t = math.sin(theta)
                a = sin_t / theta
                b = aj = (1.0 - math.cos(theta)) / theta2
                bj = (theta - sin_t) / (theta2 * theta)
            xy, xz, yz = drx * dry, drx * drz, dry * drz
            s0, s1, s2 = -(zz + yy), -(zz + xx), -(yy + xx)  # diagonal of [φ]×²
            e0, e1, e2 = 1.0 + b * s0, -a * drz + b * xy, a * dry + b * xz
            e3, e4, e5 = a * drz + b * xy, 1.0 + b * s1, -a * drx + b * yz
            e6, e7, e8 = -a * dry + b * xz, a * drx + b * yz, 1.0 + b * s2
            j0, j1, j2 = 1.0 + bj * s0, -aj * drz + bj * xy, aj * dry + bj * xz
            j3, j4, j5 = aj * drz + bj * xy, 1.0 + bj * s1, -aj * drx + bj * yz
            j6, j7, j8 = -aj * dry + bj * xz, aj * drx + bj * yz, 1.0 + bj * s2
            f0, f1, f2, f3, f4, f5, f6, f7, f8 = ref_rot
            d0 = e0 * f0 + e1 * f3 + e2 * f6
            d1 = e0 * f1 + e1 * f4 + e2 * f7
            d2 = e0 * f2 + e1 * f5 + e2 * f8
            d3 = e3 * f0 + e4 * f3 + e5 * f6
            d4 = e3 * f1 + e4 * f4 + e5 * f7
            d5 = e3 * f2 + e4 * f5 + e5 * f8
            d6 = e6 * f0 + e7 * f3 + e8 * f6
            d7 = e6 * f1 + e7 * f4 + e8 * f7
            d8 = e6 * f2 + e7 * f5 + e8 * f8
            ox = j0 * vrx + j1 * vry + j2 * vrz
            oy = j3 * vrx + j4 * vry + j5 * vrz
            oz = j6 * vrx + j7 * vry + j8 * vrz
            # (19): x_r is locked, so ẋ_dγ = ẋ̃; (20): shift to the contact centre with
            # Ṙ_d ᶦp = ω_d × R_d ᶦp. Target = (20) less the sliding term ⁰R_i ᶦṗ_η of (8).
            qx = d0 * px + d1 * py + d2 * pz
            qy = d3 * px + d4 * py + d5 * pz
            qz = d6 * px + d7 * py + d8 * pz
            sx = r0 * px + r1 * py + r2 * pz
            sy = r3 * px + r4 * py + r5 * pz
            sz = r6 * px + r7 * py + r8 * pz
            gx, gy, gz = ref_pos
            ex, ey, ez = pos
            lin_x = k_p * ((((gx + dx) - ex) + qx) - sx) + vx + (oy * qz - oz * qy)
            lin_y = k_p * ((((gy + dy) - ey) + qy) - sy) + vy + (oz * qx - ox * qz)
            lin_z = k_p * ((((gz + dz) - ez) + qz) - sz) + vz + (ox * qy - oy * qx)
            # log(R_d ⁰R_iᵀ)^∨: log_of_product_transpose_f inlined but for its branch near π.
            tr = ((d0 * r0 + d1 * r1 + d2 * r2) + (d3 * r3 + d4 * r4 + d5 * r5)) + (
                d6 * r6 + d7 * r7 + d8 * r8
            )
            cos_t = 0.5 * (tr - 1.0)
            cos_t = cos_t if cos_t > -1.0 else -1.0  # = min(1, max(−1, ·)), NaN included
            cos_t = cos_t if cos_t < 1.0 else 1.0
            theta = math.acos(cos_t)
            if theta < 1e-6:
                k_log = 0.5 * (1.0 + theta * theta / 6.0)
            elif math.pi - theta > 1e-4:
                k_log = theta / (2.0 * math.sin(theta))
            else:
                k_log = 0.0
            if k_log != 0.0:
                lx = k_log * ((d6 * r3 + d7 * r4 + d8 * r5) - (d3 * r6 + d4 * r7 + d5 * r8))
                ly = k_log * ((d0 * r6 + d1 * r7 + d2 * r8) - (d6 * r0 + d7 * r1 + d8 * r2))
                lz = k_log * ((d3 * r0 + d4 * r1 + d5 * r2) - (d0 * r3 + d1 * r4 + d2 * r5))
            else:
                lx, ly, lz = log_of_product_transpose_f((d0, d1, d2, d3, d4, d5, d6, d7, d8), rot)
            ang = [k_p * lx + ox, k_p * ly + oy, k_p * lz + oz]
            if rate is not None:
                ax, ay, az = rate
                sdx = d0 * ax + d1 * ay + d2 * az
                sdy = d3 * ax + d4 * ay + d5 * az
                sdz = d6 * ax + d7 * ay + d8 * az
                ssx = r0 * ax + r1 * ay + r2 * az
                ssy = r3 * ax + r4 * ay + r5 * az
                ssz = r6 * ax + r7 * ay + r8 * az
                values = [
                    lin_x + (sdx - ssx), lin_y + (sdy - ssy), lin_z + (sdz - ssz), *ang,
                    lin_x + sdx, lin_y + sdy, lin_z + sdz, *ang,
                ]
            else:
                values = [lin_x, lin_y, lin_z, *ang, lin_x, lin_y, lin_z, *ang]
        else:
            # Inactive: the task only holds the link (x_d = x_γ), whatever slides on it.
            phase = _INACTIVE
            values = [0.0] * 12
        k = self.k_eta
        values += wrench
        values += deflection
        values += deflection_velocity
        values += (px, py, pz, k * mux, k * muy, k * muz)
        # TaskOutput.from_values inlined: one object per link and step in the hot path.
        out = _new_object(TaskOutput)
        out._link, out._phase, out._psi_raw = self._link, phase, psi_raw
        out._psi = psi_raw if psi_raw > thr else thr
        out._in_contact, out._values = in_contact, values
        return out
