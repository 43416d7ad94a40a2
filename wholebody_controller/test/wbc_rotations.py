"""Independent SO(3) maps for the tests (scipy), never the production code's formulas.

``exp``/``log`` come from ``scipy.spatial.transform.Rotation``; ``J_l(φ) φ̇`` from the matrix
exponential of a block matrix: for ``A(t) = [φ(t)]×``, the top-right block of
``expm([[A, Ȧ], [0, A]])`` is the derivative of ``expm(A)`` along ``Ȧ`` (Van Loan), so
``[ω]× = (d/dt exp(A)) exp(A)ᵀ`` holds exactly, with no series or finite difference.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy.linalg import expm
from scipy.spatial.transform import Rotation

Array = NDArray[np.float64]


def hat(v: Array) -> Array:
    """``[v]×``."""
    x, y, z = (float(c) for c in v)
    return np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])


def exp_rotvec(phi: Array) -> Array:
    """Rotation matrix of a rotation vector [rad]."""
    return Rotation.from_rotvec(np.asarray(phi, dtype=float)).as_matrix()


def log_rotation(rot: Array) -> Array:
    """Rotation vector [rad] of a rotation matrix."""
    return Rotation.from_matrix(np.asarray(rot, dtype=float)).as_rotvec()


def world_angular_velocity(phi: Array, phi_rate: Array) -> Array:
    """ω [rad/s] of ``R(t) = exp([φ(t)]×) R₀`` at φ with rate φ̇ (= J_l(φ) φ̇)."""
    a, a_dot = hat(phi), hat(phi_rate)
    block = np.zeros((6, 6))
    block[0:3, 0:3] = a
    block[0:3, 3:6] = a_dot
    block[3:6, 3:6] = a
    m = expm(block)
    w = m[0:3, 3:6] @ m[0:3, 0:3].T
    return np.array([w[2, 1], w[0, 2], w[1, 0]])
