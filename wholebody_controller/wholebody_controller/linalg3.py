"""3-vectors and 3×3 matrices as plain floats (row-major 9-tuples) for the control step.

At this size one numpy call costs as much as dozens of float operations (design §5), so the
per-contact arithmetic of (8)–(20) runs on Python floats; these are its few building blocks.
"""

from __future__ import annotations

from phri_common.jit import jitable
from wholebody_controller.so3 import Mat9, Vec3


@jitable
def rotate(m: Mat9, v: Vec3) -> Vec3:
    """``M v``."""
    m0, m1, m2, m3, m4, m5, m6, m7, m8 = m
    x, y, z = v
    return m0 * x + m1 * y + m2 * z, m3 * x + m4 * y + m5 * z, m6 * x + m7 * y + m8 * z


@jitable
def rotate_pair(m: Mat9, u: Vec3, v: Vec3) -> tuple[float, float, float, float, float, float]:
    """``(M u, M v)`` as six floats (one call for two vectors in the same frame)."""
    m0, m1, m2, m3, m4, m5, m6, m7, m8 = m
    ux, uy, uz = u
    vx, vy, vz = v
    return (m0 * ux + m1 * uy + m2 * uz, m3 * ux + m4 * uy + m5 * uz, m6 * ux + m7 * uy + m8 * uz,
            m0 * vx + m1 * vy + m2 * vz, m3 * vx + m4 * vy + m5 * vz, m6 * vx + m7 * vy + m8 * vz)


@jitable
def matmul(a: Mat9, b: Mat9) -> tuple[float, ...]:
    """``A B``."""
    a0, a1, a2, a3, a4, a5, a6, a7, a8 = a
    b0, b1, b2, b3, b4, b5, b6, b7, b8 = b
    return (
        a0 * b0 + a1 * b3 + a2 * b6, a0 * b1 + a1 * b4 + a2 * b7, a0 * b2 + a1 * b5 + a2 * b8,
        a3 * b0 + a4 * b3 + a5 * b6, a3 * b1 + a4 * b4 + a5 * b7, a3 * b2 + a4 * b5 + a5 * b8,
        a6 * b0 + a7 * b3 + a8 * b6, a6 * b1 + a7 * b4 + a8 * b7, a6 * b2 + a7 * b5 + a8 * b8,
    )


@jitable
def matmul_transpose(a: Mat9, b: Mat9) -> tuple[float, ...]:
    """``A Bᵀ`` (entry ij: row i of A · row j of B)."""
    a0, a1, a2, a3, a4, a5, a6, a7, a8 = a
    b0, b1, b2, b3, b4, b5, b6, b7, b8 = b
    return (
        a0 * b0 + a1 * b1 + a2 * b2, a0 * b3 + a1 * b4 + a2 * b5, a0 * b6 + a1 * b7 + a2 * b8,
        a3 * b0 + a4 * b1 + a5 * b2, a3 * b3 + a4 * b4 + a5 * b5, a3 * b6 + a4 * b7 + a5 * b8,
        a6 * b0 + a7 * b1 + a8 * b2, a6 * b3 + a7 * b4 + a8 * b5, a6 * b6 + a7 * b7 + a8 * b8,
    )
