"""Cartesian admittance (13) discretised exactly for a zero-order-hold wrench.

The continuous law ``Λ ẍ̃ + D ẋ̃ + K x̃ = w`` (13) is the linear system ``ṡ = A s + B w`` with
``s = [x̃; ẋ̃]``, ``A = [[0, I], [−Λ⁻¹K, −Λ⁻¹D]]``, ``B = [0; Λ⁻¹]``. The wrench is sampled once per
control period and held (zero-order hold), so the exact discrete system is

    s[k+1] = Φ s[k] + Γ w[k],    Φ = e^{A·dt},    Γ = ∫₀^dt e^{Aτ} dτ · B,

computed once per (Λ, D, K, dt) with one matrix exponential of the augmented 18×18 matrix
``[[A, B], [0, 0]]``. Every eigenvalue ``e^{λ dt}`` of Φ has modulus ≤ 1 whenever the continuous
system is stable (Λ ≻ 0, D, K ⪰ 0), whatever dt: unlike explicit Euler — unstable once
``D/Λ · dt > 2``, which the waltz set (Λ = 0.1, D = 200) reaches at 100 Hz with 20 — this scheme
holds for every parameter set of the paper at 100–500 Hz and reproduces the continuous response
at the sample instants.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray
from scipy.linalg import expm

from phri_common.jit import jitable

Array = NDArray[np.float64]


def discretise(
    inertia: Array, damping: Array, stiffness: Array, dt: float
) -> tuple[Array, Array]:
    """Exact zero-order-hold discretisation ``(Φ 12×12, Γ 12×6)`` of (13).

    Args:
        inertia: Λ (6×6, symmetric positive definite).
        damping: D (6×6).
        stiffness: K (6×6).
        dt: sample period [s], > 0.
    """
    if dt <= 0.0 or not np.isfinite(dt):
        raise ValueError(f"admittance sample period must be > 0, got {dt}")
    lam_inv = np.linalg.inv(inertia)
    a = np.zeros((18, 18))
    a[0:6, 6:12] = np.eye(6)
    a[6:12, 0:6] = -lam_inv @ stiffness
    a[6:12, 6:12] = -lam_inv @ damping
    a[6:12, 12:18] = lam_inv
    m = expm(a * dt)
    return m[0:12, 0:12].copy(), m[0:12, 12:18].copy()


def transition(inertia: Array, damping: Array, stiffness: Array, dt: float) -> Array:
    """``[Φ Γ]`` (12×18) of :func:`discretise`, the form :func:`admittance_step` takes."""
    phi, gamma = discretise(inertia, damping, stiffness, dt)
    return np.ascontiguousarray(np.hstack([phi, gamma]))


@jitable
def admittance_step(state: Array, phi_gamma: Array, wrench: tuple[float, ...]) -> None:
    """(13) over one period: ``[x̃; ẋ̃] ← Φ [x̃; ẋ̃] + Γ w``, in place.

    ``state`` holds x̃ [m, rad] then ẋ̃ [m/s, rad/s] (12 floats), ``phi_gamma`` is ``[Φ Γ]``
    (12×18, :func:`transition`), ``wrench`` w [N, N·m] (6 floats). Written as loops: at this
    size the compiled kernel's loops beat a call into BLAS.
    """
    old = state[0:12].copy()
    for r in range(12):
        acc = 0.0
        for j in range(12):
            acc += phi_gamma[r, j] * old[j]
        for j in range(6):
            acc += phi_gamma[r, 12 + j] * wrench[j]
        state[r] = acc


@jitable
def turn_gate(wrench: tuple[float, ...], force: float,
              limit: float) -> tuple[float, float, float, float, float, float]:
    """The admittance's torque input gated by the contact force (T1): with ``limit`` F_t > 0
    [N] the torque of ``wrench`` (6 floats, [N, N·m]) is scaled by

        g = clip((1.5 F_t − ‖f‖) / (0.5 F_t), 0, 1)                                     (T1)

    of the contact force ‖f‖ = ``force`` [N]: whole up to F_t, fading linearly to nothing at
    1.5 F_t; the force part is kept. A partner leads a turn with a hold-sized force; a push far
    above it (a shove and its aftermath) is no turn lead, and turning the base at its limit
    under it sweeps the robot's unskinned links into the partner (docs/wholebody_controller.md,
    "Following a turning partner"). F_t = 0 is the paper's (13)."""
    fx, fy, fz, tx, ty, tz = wrench
    if limit <= 0.0 or force <= limit:
        return (fx, fy, fz, tx, ty, tz)
    g = max(0.0, min(1.0, (1.5 * limit - force) / (0.5 * limit)))
    return (fx, fy, fz, g * tx, g * ty, g * tz)


@jitable
def dead_zone(wrench: tuple[float, ...], force_band: float,
              torque_band: float) -> tuple[float, float, float, float, float, float]:
    """The admittance's input with a dead zone (D1): the force and the torque of ``wrench``
    (6 floats, [N, N·m]) each shrunk towards zero by its band δ [N], [N·m]::

        w_f' = w_f · max(0, 1 − δ_f / ‖w_f‖),     w_τ' = w_τ · max(0, 1 − δ_τ / ‖w_τ‖)      (D1)

    Below its band a part moves nothing, so the skin's noise around a still hold leaves (13) at
    rest; above it the part keeps its direction and loses δ of its size, so the map is
    continuous (no relay) and ‖w − w'‖ ≤ δ per part. δ = 0 is the paper's (13).
    """
    fx, fy, fz, tx, ty, tz = wrench
    f = math.sqrt(fx * fx + fy * fy + fz * fz)
    kf = 0.0 if f <= force_band else 1.0 - force_band / f
    t = math.sqrt(tx * tx + ty * ty + tz * tz)
    kt = 0.0 if t <= torque_band else 1.0 - torque_band / t
    return (kf * fx, kf * fy, kf * fz, kt * tx, kt * ty, kt * tz)
