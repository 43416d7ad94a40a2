"""The equations of one contact centre's interaction task: (12), (14)–(20), fn. 2 (pure).

Frames. Contact states arrive in the link frame γ_i (DH frame): centre ᶦp_η, force ᶦf_η (on the
link), torque ᶦτ_η and the contact region Ω_i. Everything the admittance and the QP use is in the
world frame 0, obtained with the link pose (⁰R_i, ⁰p_γi).

Desired region. The paper writes the track force as ⁰μ but builds Ω_i from taxel positions, which
are link-frame coordinates (III-A). We keep both Ω_i and Ω_d in the link frame — so Ω_d is a patch
of skin, locked at onset, and a robot motion without sliding never creates a track force — evaluate
(11) there, and rotate the result to the world with ⁰R_i before (12).

Each function below is one equation group on plain Python floats (rotations as row-major
9-tuples, :mod:`~wholebody_controller.linalg3`), :func:`jitable` so that the compiled step runs
the same code; :mod:`~wholebody_controller.task_step` puts them together with Algorithm 1 and the
contact safety into the step of one link. ``test/wbc_reference.py`` is an independent numpy/scipy
version of the whole step, the oracle of ``test_equivalence.py``.
"""

from __future__ import annotations

import enum
import math
from collections.abc import Sequence
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from phri_common.jit import jitable
from wholebody_controller.contact_safety import Safety
from wholebody_controller.linalg3 import matmul, matmul_transpose, rotate, rotate_pair
from wholebody_controller.so3 import Mat9, Vec3, exp_and_left_jacobian, log

Array = NDArray[np.float64]

#: Layout of the 36 floats of :attr:`TaskOutput.values`.
TARGET, CONTROL, WRENCH = slice(0, 6), slice(6, 12), slice(12, 18)
DEFLECTION, DEFLECTION_VELOCITY = slice(18, 24), slice(24, 30)
POINT, TRACK_FORCE = slice(30, 33), slice(33, 36)
N_VALUES = 36


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

@jitable
def contact_rate(center: Vec3, previous: Vec3, dt: float) -> Vec3:
    """ᶦṗ_η [m/s]: the contact centre's rate on the link, a difference over one period (fn. 2)."""
    return ((center[0] - previous[0]) / dt, (center[1] - previous[1]) / dt,
            (center[2] - previous[2]) / dt)


@jitable
def contact_wrench(force: Vec3, torque: Vec3, mu: Vec3, k_eta: float, rot: Mat9) -> list[float]:
    """⁰w_η (12) [N, N·m]: ``[⁰R_i (ᶦf_η + k_η ᶦμ); ⁰R_i ᶦτ_η]`` (link-frame inputs, world out).

    ``force`` is the estimated force on the link (9a) [N], ``torque`` the torque about the
    contact centre (9b) [N·m], ``mu`` the track force (11) [m] in the link frame, ``k_eta`` [N/m].
    """
    pushed = (force[0] + k_eta * mu[0], force[1] + k_eta * mu[1], force[2] + k_eta * mu[2])
    return list(rotate_pair(rot, pushed, torque))


@jitable
def priority(deflection_velocity: Sequence[float], b: float) -> float:
    """ψ (15) = (1 − e^{−b‖ẋ̃‖²}) / (1 + e^{−b‖ẋ̃‖²}) = tanh(b‖ẋ̃‖²/2) ∈ [0, 1).

    ``deflection_velocity`` is ẋ̃ [m/s, rad/s] (6 floats), ``b`` [s²/m²].
    """
    v0, v1, v2, v3, v4, v5 = deflection_velocity
    return math.tanh(0.5 * b * (v0 * v0 + v1 * v1 + v2 * v2 + v3 * v3 + v4 * v4 + v5 * v5))


@jitable
def desired_orientation(ref_rot: Mat9, rotation_deflection: Vec3,
                        rotation_deflection_rate: Vec3) -> tuple[tuple[float, ...], Vec3]:
    """(14) for the rotation: ``⁰R_d = exp([x̃_ω]×) ⁰R_r`` and its angular velocity
    ``⁰ω_d = J_l(x̃_ω) ẋ̃_ω`` [rad/s] (x_r is locked, so only the deflection moves R_d)."""
    exp_d, jac_l = exp_and_left_jacobian(rotation_deflection)
    return matmul(exp_d, ref_rot), rotate(jac_l, rotation_deflection_rate)


@jitable
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


@jitable
def sliding_terms(rot_d: Mat9, rot: Mat9, rate: Vec3) -> tuple[Vec3, Vec3]:
    """``(⁰R_d ᶦṗ_η, ⁰R_i ᶦṗ_η)`` [m/s]: the sliding term of the desired velocity (17), (20)
    and the one of the contact-centre velocity (8), which the QP target leaves out."""
    return rotate(rot_d, rate), rotate(rot, rate)


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
