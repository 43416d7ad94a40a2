"""SO(3) helpers used by the task-space controller (pure numpy).

The orientation error of (19) and the rotational part of the deflection (14) are rotation vectors
(the logarithm of a rotation, ``log(R)^∨``); these functions map between the two representations.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

Array = NDArray[np.float64]

_SMALL = 1e-8
_EYE3 = np.eye(3)
_EYE3.flags.writeable = False


def skew(v: Array) -> Array:
    """The skew-symmetric matrix ``[v]×`` with ``[v]× w = v × w``."""
    x, y, z = float(v[0]), float(v[1]), float(v[2])
    return np.array(((0.0, -z, y), (z, 0.0, -x), (-y, x, 0.0)))


def cross(a: Array, b: Array) -> Array:
    """a × b for 3-vectors (cheaper than ``np.cross`` for one pair)."""
    a0, a1, a2 = float(a[0]), float(a[1]), float(a[2])
    b0, b1, b2 = float(b[0]), float(b[1]), float(b[2])
    return np.array((a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0))


def exp_and_left_jacobian_so3(phi: Array) -> tuple[Array, Array]:
    """``(exp([φ]×), J_l(φ))`` sharing the work (see :func:`exp_so3`, :func:`left_jacobian_so3`)."""
    theta2 = float(phi @ phi)
    if theta2 == 0.0:
        return _EYE3.copy(), _EYE3.copy()
    theta = math.sqrt(theta2)
    k = skew(phi)
    k2 = k @ k
    if theta < 1e-5:
        return _EYE3 + k + 0.5 * k2, _EYE3 + 0.5 * k + k2 / 6.0
    s, c = math.sin(theta), math.cos(theta)
    b = (1.0 - c) / theta2
    return _EYE3 + (s / theta) * k + b * k2, _EYE3 + b * k + ((theta - s) / (theta2 * theta)) * k2


def exp_so3(phi: Array) -> Array:
    """Rotation matrix ``exp([φ]×)`` of a rotation vector ``φ`` [rad] (Rodrigues)."""
    theta = math.sqrt(float(phi @ phi))
    k = skew(phi)
    if theta < _SMALL:
        return _EYE3 + k + 0.5 * (k @ k)
    a = math.sin(theta) / theta
    b = (1.0 - math.cos(theta)) / theta**2
    return _EYE3 + a * k + b * (k @ k)


def log_so3(rot: Array) -> Array:
    """Rotation vector ``log(R)^∨`` [rad] of a rotation matrix, with angle in [0, π].

    Near π the axis is taken from the symmetric part of ``R`` (the antisymmetric part vanishes
    there), so the result stays accurate for every rotation.
    """
    cos_theta = min(1.0, max(-1.0, 0.5 * (float(np.trace(rot)) - 1.0)))
    theta = math.acos(cos_theta)
    w = np.array([rot[2, 1] - rot[1, 2], rot[0, 2] - rot[2, 0], rot[1, 0] - rot[0, 1]])
    if theta < 1e-6:
        # log(R) ≈ (R − Rᵀ)^∨ / 2 · (1 + θ²/6)
        return 0.5 * w * (1.0 + theta**2 / 6.0)
    if math.pi - theta > 1e-4:
        return (theta / (2.0 * math.sin(theta))) * w
    # Near π: R ≈ 2 a aᵀ − I, take the axis from the largest diagonal element.
    sym = 0.5 * (rot + rot.T)
    outer = (sym - cos_theta * _EYE3) / (1.0 - cos_theta)
    i = int(np.argmax(np.diag(outer)))
    axis = outer[:, i] / math.sqrt(max(outer[i, i], 1e-300))
    if float(axis @ w) < 0.0:
        axis = -axis
    return theta * axis


def left_jacobian_so3(phi: Array) -> Array:
    """Left Jacobian ``J_l(φ)``: for ``R(t) = exp([φ(t)]×) R₀`` the world angular velocity is
    ``ω = J_l(φ) φ̇`` [rad/s]."""
    theta = math.sqrt(float(phi @ phi))
    k = skew(phi)
    if theta < 1e-5:
        return _EYE3 + 0.5 * k + (k @ k) / 6.0
    return (
        _EYE3
        + ((1.0 - math.cos(theta)) / theta**2) * k
        + ((theta - math.sin(theta)) / theta**3) * (k @ k)
    )


# -- scalar versions for the control step ---------------------------------------------------------
# The control step works on 3-vectors and 3×3 matrices; there, one numpy call (µs) costs as much as
# dozens of float operations, so the hot path uses these plain-float forms of the functions above
# (row-major 9-tuples for matrices). They compute the same formulas; test_so3.py checks them
# against the array versions.

Mat9 = Sequence[float]


_EYE9 = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)


def exp_and_left_jacobian_f(x: float, y: float, z: float) -> tuple[Mat9, Mat9]:
    """``(exp([φ]×), J_l(φ))`` of φ = (x, y, z) [rad] as row-major 9-tuples.

    Both are ``I + α [φ]× + β [φ]×²`` with ``[φ]×² = φφᵀ − θ² I`` (see
    :func:`exp_and_left_jacobian_so3` for the coefficients and the small-angle branch).
    """
    theta2 = x * x + y * y + z * z
    if theta2 == 0.0:
        return _EYE9, _EYE9
    if theta2 < 1e-10:  # θ < 1e-5
        a, b, aj, bj = 1.0, 0.5, 0.5, 1.0 / 6.0
    else:
        theta = math.sqrt(theta2)
        s, c = math.sin(theta), math.cos(theta)
        a = s / theta
        b = aj = (1.0 - c) / theta2
        bj = (theta - s) / (theta2 * theta)
    xx, yy, zz = x * x, y * y, z * z
    xy, xz, yz = x * y, x * z, y * z
    d0, d1, d2 = -(zz + yy), -(zz + xx), -(yy + xx)  # diagonal of [φ]×²
    exp = (
        1.0 + b * d0, -a * z + b * xy, a * y + b * xz,
        a * z + b * xy, 1.0 + b * d1, -a * x + b * yz,
        -a * y + b * xz, a * x + b * yz, 1.0 + b * d2,
    )
    jac = (
        1.0 + bj * d0, -aj * z + bj * xy, aj * y + bj * xz,
        aj * z + bj * xy, 1.0 + bj * d1, -aj * x + bj * yz,
        -aj * y + bj * xz, aj * x + bj * yz, 1.0 + bj * d2,
    )
    return exp, jac


def log_of_product_transpose_f(a: Mat9, b: Mat9) -> tuple[float, float, float]:
    """``log(A Bᵀ)^∨`` [rad] for rotations A, B given as row-major 9-tuples.

    Only the trace and the antisymmetric part of ``A Bᵀ`` are formed; within 1e-4 of π the full
    product goes through :func:`log_so3` (axis from the symmetric part).
    """
    a0, a1, a2, a3, a4, a5, a6, a7, a8 = a
    b0, b1, b2, b3, b4, b5, b6, b7, b8 = b
    # (A Bᵀ)_ij = row i of A · row j of B
    m01 = a0 * b3 + a1 * b4 + a2 * b5
    m02 = a0 * b6 + a1 * b7 + a2 * b8
    m10 = a3 * b0 + a4 * b1 + a5 * b2
    m12 = a3 * b6 + a4 * b7 + a5 * b8
    m20 = a6 * b0 + a7 * b1 + a8 * b2
    m21 = a6 * b3 + a7 * b4 + a8 * b5
    trace = (a0 * b0 + a1 * b1 + a2 * b2) + (a3 * b3 + a4 * b4 + a5 * b5) + (
        a6 * b6 + a7 * b7 + a8 * b8
    )
    cos_theta = min(1.0, max(-1.0, 0.5 * (trace - 1.0)))
    theta = math.acos(cos_theta)
    wx, wy, wz = m21 - m12, m02 - m20, m10 - m01
    if theta < 1e-6:
        k = 0.5 * (1.0 + theta * theta / 6.0)
    elif math.pi - theta > 1e-4:
        k = theta / (2.0 * math.sin(theta))
    else:
        product = np.array(a).reshape(3, 3) @ np.array(b).reshape(3, 3).T
        rx, ry, rz = log_so3(product).tolist()
        return rx, ry, rz
    return k * wx, k * wy, k * wz
