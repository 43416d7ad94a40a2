"""The SO(3) maps of the task-space controller, on plain floats (the one implementation).

The orientation error of (19) and the rotational part of the deflection (14) are rotation vectors
φ [rad] (the logarithm of a rotation, ``log(R)^∨``). The control step works on 3-vectors and 3×3
matrices, where one numpy call costs as much as dozens of float operations, so these maps take and
return Python floats: rotation vectors as 3-tuples, matrices as row-major 9-tuples (``Mat9``).
``test/test_so3.py`` checks every map against scipy's ``Rotation`` / matrix exponential and
against finite differences.

With ``K = [φ]×`` and ``θ = ‖φ‖``, ``K² = φφᵀ − θ²I`` and

    exp(K)  = I + (sin θ / θ) K + ((1 − cos θ) / θ²) K²          (Rodrigues)
    J_l(φ)  = I + ((1 − cos θ) / θ²) K + ((θ − sin θ) / θ³) K²    (left Jacobian)

so that for ``R(t) = exp([φ(t)]×) R₀`` the world angular velocity is ``ω = J_l(φ) φ̇`` [rad/s].
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from phri_common.jit import jitable

Mat9 = Sequence[float]
"""A 3×3 matrix as 9 floats, row-major."""
Vec3 = tuple[float, float, float]

IDENTITY: tuple[float, ...] = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)

_SERIES_THETA2 = 1e-4
"""Below this θ² [rad²] the coefficients use their Taylor series (first omitted term < 1e-15)."""


@jitable
def coefficients(theta2: float) -> tuple[float, float, float]:
    """``(sin θ/θ, (1 − cos θ)/θ², (θ − sin θ)/θ³)`` for ``θ² = theta2`` [rad²].

    Near 0 the closed forms lose digits to cancellation, so their Taylor series are used there:
    1 − θ²/6 + θ⁴/120, 1/2 − θ²/24 + θ⁴/720, 1/6 − θ²/120 + θ⁴/5040.
    """
    if theta2 < _SERIES_THETA2:
        t4 = theta2 * theta2
        return (1.0 - theta2 / 6.0 + t4 / 120.0, 0.5 - theta2 / 24.0 + t4 / 720.0,
                1.0 / 6.0 - theta2 / 120.0 + t4 / 5040.0)
    theta = math.sqrt(theta2)
    sin_t = math.sin(theta)
    return sin_t / theta, (1.0 - math.cos(theta)) / theta2, (theta - sin_t) / (theta2 * theta)


@jitable
def exp_and_left_jacobian(phi: Vec3) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """``(exp([φ]×), J_l(φ))`` of a rotation vector φ [rad], sharing the trigonometry.

    Both are ``I + α [φ]× + β [φ]×²`` with ``[φ]×² = φφᵀ − θ²I``: (α, β) = (a, b) for exp and
    (b, c) for J_l, with (a, b, c) from :func:`coefficients`.
    """
    x, y, z = phi
    xx, yy, zz, xy, xz, yz = x * x, y * y, z * z, x * y, x * z, y * z
    a, b, c = coefficients(xx + yy + zz)
    s0, s1, s2 = yy + zz, xx + zz, xx + yy  # minus the diagonal of [φ]×²
    exp_phi = (1.0 - b * s0, b * xy - a * z, b * xz + a * y,
               b * xy + a * z, 1.0 - b * s1, b * yz - a * x,
               b * xz - a * y, b * yz + a * x, 1.0 - b * s2)
    jac = (1.0 - c * s0, c * xy - b * z, c * xz + b * y,
           c * xy + b * z, 1.0 - c * s1, c * yz - b * x,
           c * xz - b * y, c * yz + b * x, 1.0 - c * s2)
    return exp_phi, jac


@jitable
def exp(phi: Vec3) -> tuple[float, ...]:
    """Rotation matrix ``exp([φ]×)`` of a rotation vector φ [rad] (Rodrigues)."""
    return exp_and_left_jacobian(phi)[0]


@jitable
def left_jacobian(phi: Vec3) -> tuple[float, ...]:
    """Left Jacobian ``J_l(φ)``: ``ω = J_l(φ) φ̇`` for ``R = exp([φ]×) R₀`` [rad/s]."""
    return exp_and_left_jacobian(phi)[1]


@jitable
def log(rot: Mat9) -> Vec3:
    """Rotation vector ``log(R)^∨`` [rad] of a rotation matrix, with angle θ in [0, π].

    ``log(R)^∨ = θ / (2 sin θ) · (R − Rᵀ)^∨``, with θ = atan2(sin θ, cos θ) from
    ``‖(R − Rᵀ)^∨‖ = 2 sin θ`` and ``tr R = 1 + 2 cos θ``: unlike acos of the trace alone, this
    keeps θ accurate to rounding near 0 and near π. Within 1e-4 of π the antisymmetric part
    vanishes, so the axis comes from the symmetric part there (:func:`_log_near_pi`).
    """
    r0, r1, r2, r3, r4, r5, r6, r7, r8 = rot
    wx, wy, wz = r7 - r5, r2 - r6, r3 - r1
    sin_t = 0.5 * math.sqrt(wx * wx + wy * wy + wz * wz)
    theta = math.atan2(sin_t, 0.5 * (r0 + r4 + r8 - 1.0))
    if theta < 1e-6:
        k = 0.5 * (1.0 + theta * theta / 6.0)  # θ / (2 sin θ) by its series
    elif math.pi - theta > 1e-4:
        k = theta / (2.0 * sin_t)
    else:
        return _log_near_pi(rot, theta, (wx, wy, wz))
    return k * wx, k * wy, k * wz


@jitable
def _log_near_pi(rot: Mat9, theta: float, antisym: Vec3) -> Vec3:
    """``log(R)^∨`` for θ near π: ``(R + Rᵀ)/2 = cos θ I + (1 − cos θ) a aᵀ`` gives the axis a
    from its largest diagonal entry (the first of equal ones); the sign is the one of the (tiny)
    antisymmetric part. Straight-line code, so the compiled step can use it too."""
    r0, r1, r2, r3, r4, r5, r6, r7, r8 = rot
    cos_t = math.cos(theta)
    scale = 1.0 / (1.0 - cos_t)
    xy, xz, yz = 0.5 * (r1 + r3) * scale, 0.5 * (r2 + r6) * scale, 0.5 * (r5 + r7) * scale
    xx, yy, zz = (r0 - cos_t) * scale, (r4 - cos_t) * scale, (r8 - cos_t) * scale
    if xx >= yy and xx >= zz:
        col = (xx, xy, xz)
    elif yy >= zz:
        col = (xy, yy, yz)
    else:
        col = (xz, yz, zz)
    norm = math.sqrt(max(max(xx, yy, zz), 1e-300))
    ax, ay, az = col[0] / norm, col[1] / norm, col[2] / norm
    if ax * antisym[0] + ay * antisym[1] + az * antisym[2] < 0.0:
        ax, ay, az = -ax, -ay, -az
    return theta * ax, theta * ay, theta * az
