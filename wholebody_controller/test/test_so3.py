"""The production SO(3) maps (plain floats) against scipy and against finite differences.

The references are independent of ``so3.py`` (``wbc_rotations``: scipy's Rotation and a block
matrix exponential), and the cases cover every branch production runs: the series near θ = 0
(θ² < 1e-4), the closed forms, and the axis-from-symmetric-part branch within 1e-4 of π.
"""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from wbc_rotations import exp_rotvec, log_rotation, world_angular_velocity

from wholebody_controller import so3

unit_box = arrays(np.float64, 3, elements=st.floats(-1.0, 1.0))
SCALES = [0.0, 1e-12, 1e-6, 3e-3, 9.9e-3, 1.01e-2, 0.3, 1.0, 2.5, math.pi - 2e-4]


def direction(v: np.ndarray) -> np.ndarray:
    norm = float(np.linalg.norm(v))
    return v / norm if norm > 1e-3 else np.array([0.0, 0.6, 0.8])


def matrix(m: tuple[float, ...]) -> np.ndarray:
    return np.reshape(m, (3, 3))


@settings(max_examples=300, deadline=None)
@given(unit_box, st.sampled_from(SCALES))
def test_exp_matches_scipy(axis: np.ndarray, angle: float) -> None:
    phi = direction(axis) * angle
    np.testing.assert_allclose(matrix(so3.exp(tuple(phi))), exp_rotvec(phi), rtol=0, atol=1e-14)


@settings(max_examples=300, deadline=None)
@given(unit_box, unit_box, st.sampled_from(SCALES))
def test_left_jacobian_matches_the_block_exponential(axis: np.ndarray, rate: np.ndarray,
                                                     angle: float) -> None:
    phi = direction(axis) * angle
    got = matrix(so3.left_jacobian(tuple(phi))) @ rate
    np.testing.assert_allclose(got, world_angular_velocity(phi, rate), rtol=0, atol=1e-13)


@settings(max_examples=100, deadline=None)
@given(unit_box, unit_box, st.sampled_from([1e-3, 0.3, 1.0, 2.5]))
def test_left_jacobian_by_finite_differences_of_exp(axis: np.ndarray, rate: np.ndarray,
                                                    angle: float) -> None:
    # [ω]× = Ṙ Rᵀ with Ṙ a central difference of the production exp itself.
    phi, h = direction(axis) * angle, 1e-6
    rot_dot = (matrix(so3.exp(tuple(phi + h * rate))) - matrix(so3.exp(tuple(phi - h * rate))))
    w = rot_dot / (2 * h) @ matrix(so3.exp(tuple(phi))).T
    omega = np.array([w[2, 1], w[0, 2], w[1, 0]])
    np.testing.assert_allclose(matrix(so3.left_jacobian(tuple(phi))) @ rate, omega, atol=1e-8)


@settings(max_examples=300, deadline=None)
@given(unit_box, st.sampled_from([*SCALES, math.pi - 1e-5, math.pi - 1e-9, math.pi]))
def test_log_matches_scipy_on_every_branch(axis: np.ndarray, angle: float) -> None:
    rot = exp_rotvec(direction(axis) * angle)
    got = np.array(so3.log(tuple(rot.ravel())))
    expected = log_rotation(rot)
    if angle > math.pi - 1e-6:  # ±axis·π are the same rotation: compare rotations
        np.testing.assert_allclose(exp_rotvec(got), rot, atol=1e-9)
        assert abs(np.linalg.norm(got) - np.linalg.norm(expected)) < 1e-6
    else:
        np.testing.assert_allclose(got, expected, rtol=0, atol=1e-9)


def test_exp_of_z_rotation_is_rot_z() -> None:
    c, s = math.cos(0.7), math.sin(0.7)
    np.testing.assert_allclose(matrix(so3.exp((0.0, 0.0, 0.7))),
                               [[c, -s, 0], [s, c, 0], [0, 0, 1]], atol=1e-15)


def test_log_of_nan_is_nan_not_an_exception() -> None:
    assert all(math.isnan(v) for v in so3.log((math.nan,) * 9))
