"""SO(3) helpers: exp/log inverse pair, the π edge, and the left Jacobian by finite differences."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from wholebody_controller.so3 import exp_so3, left_jacobian_so3, log_so3, skew

vec3 = arrays(np.float64, 3, elements=st.floats(-1.0, 1.0))


def test_skew_is_cross_product() -> None:
    a, b = np.array([0.3, -1.2, 2.0]), np.array([-0.7, 0.1, 0.4])
    np.testing.assert_allclose(skew(a) @ b, np.cross(a, b), atol=1e-15)


def test_exp_of_z_rotation_matches_rotz() -> None:
    angle = 0.7
    c, s = math.cos(angle), math.sin(angle)
    np.testing.assert_allclose(
        exp_so3(np.array([0.0, 0.0, angle])), [[c, -s, 0], [s, c, 0], [0, 0, 1]], atol=1e-15
    )


@given(vec3, st.floats(0.0, math.pi - 1e-3))
def test_log_inverts_exp(axis: np.ndarray, angle: float) -> None:
    norm = np.linalg.norm(axis)
    if norm < 1e-3:
        axis, norm = np.array([1.0, 0.0, 0.0]), 1.0
    phi = axis / norm * angle
    rot = exp_so3(phi)
    np.testing.assert_allclose(rot @ rot.T, np.eye(3), atol=1e-12)
    np.testing.assert_allclose(log_so3(rot), phi, atol=1e-9)


def test_log_near_pi_keeps_the_angle() -> None:
    axis = np.array([1.0, 2.0, -2.0]) / 3.0
    for angle in (math.pi - 1e-6, math.pi):
        phi = log_so3(exp_so3(axis * angle))
        assert abs(np.linalg.norm(phi) - angle) < 1e-6
        np.testing.assert_allclose(exp_so3(phi), exp_so3(axis * angle), atol=1e-9)


@settings(max_examples=50)
@given(vec3, vec3)
def test_left_jacobian_gives_world_angular_velocity(phi: np.ndarray, rate: np.ndarray) -> None:
    # ω from a central difference of R(t) = exp(φ + t φ̇): [ω]× = Ṙ Rᵀ.
    h = 1e-6
    rot_dot = (exp_so3(phi + h * rate) - exp_so3(phi - h * rate)) / (2 * h)
    w = rot_dot @ exp_so3(phi).T
    omega = np.array([w[2, 1], w[0, 2], w[1, 0]])
    np.testing.assert_allclose(left_jacobian_so3(phi) @ rate, omega, atol=1e-7)
