"""Planar base geometry: the yaw rotation between the base frame and the world (pure, no ROS).

The mecanum base moves in the plane: its pose is q_b = [x, y, ψ] of ``base_link`` in ``odom``
(paper III-B, reduced base state). A planar vector given in the base frame, (v_x, v_y), has the
world components

    x' = cos ψ · v_x − sin ψ · v_y,    y' = sin ψ · v_x + cos ψ · v_y,

i.e. ``R_z(ψ) · v`` (:func:`base_to_world`); the world → base direction is ``R_z(ψ)ᵀ``
(:func:`world_to_base`). The same rotation turns a body twist into world rates of q_b (the yaw
rate is frame-free) and a base-frame force into the world. Plain floats, no numpy: the functions
sit on the controller's and the simulator's hot paths.

A planar pose's heading is read from a unit quaternion (w, x, y, z) by
:func:`yaw_from_quaternion` and written by :func:`quaternion_from_yaw`.
"""

from __future__ import annotations

import math

from phri_common.jit import jitable


@jitable
def base_to_world(yaw: float, vx: float, vy: float) -> tuple[float, float]:
    """World components (x', y') of the base-frame planar vector (v_x, v_y): ``R_z(yaw) · v``.

    Args:
        yaw: base heading ψ [rad].
        vx, vy: vector in the base frame (any unit: m/s for a twist, N for a force).

    Returns:
        (c·v_x − s·v_y, s·v_x + c·v_y) in the same unit, c = cos ψ, s = sin ψ.
    """
    c, s = math.cos(yaw), math.sin(yaw)
    return c * vx - s * vy, s * vx + c * vy


@jitable
def world_to_base(yaw: float, x: float, y: float) -> tuple[float, float]:
    """Base-frame components of the world planar vector (x, y): ``R_z(yaw)ᵀ · v``, the inverse
    of :func:`base_to_world`.

    Args:
        yaw: base heading ψ [rad].
        x, y: vector in the world frame (any unit).

    Returns:
        (c·x + s·y, −s·x + c·y) in the same unit.
    """
    c, s = math.cos(yaw), math.sin(yaw)
    return c * x + s * y, -s * x + c * y


def yaw_from_quaternion(w: float, x: float, y: float, z: float) -> float:
    """Heading ψ ∈ (−π, π] [rad] of the unit quaternion (w, x, y, z): the rotation of the body's
    x axis about the world z axis, ``atan2(2(wz + xy), 1 − 2(y² + z²))`` (the yaw of the
    Z-Y-X Euler decomposition; exact for a pure rotation about z)."""
    return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


def quaternion_from_yaw(yaw: float) -> tuple[float, float, float, float]:
    """Unit quaternion (w, x, y, z) of the rotation by ``yaw`` [rad] about z:
    (cos ψ/2, 0, 0, sin ψ/2)."""
    half = 0.5 * yaw
    return math.cos(half), 0.0, 0.0, math.sin(half)
