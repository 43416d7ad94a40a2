"""Task-space velocity control (19)–(20) and the sliding term of (8), term by term, on cases
solved by hand: each test isolates one term (the others are zero by construction), so removing
or mis-signing any term fails its test without comparing two implementations.

(19)–(20): linear ``K_p (⁰p_dγ − ⁰p_γ + ⁰R_d ᶦp_η − ⁰R_i ᶦp_η) + ẋ̃_p + ⁰ω_d × ⁰R_d ᶦp_η``,
angular ``K_p log(⁰R_d ⁰R_iᵀ)^∨ + ⁰ω_d``; the control velocity adds ``⁰R_d ᶦṗ_η`` (17), the QP
target ``⁰R_d ᶦṗ_η − ⁰R_i ᶦṗ_η`` (the sliding term of (8) moves to the right-hand side).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from wbc_rotations import exp_rotvec

from wholebody_controller.contact_task import desired_orientation, sliding_terms, task_velocity

K_P = 5.0
EYE = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)
ZERO3 = (0.0, 0.0, 0.0)
ZERO6 = (0.0,) * 6


def rz(angle: float) -> tuple[float, ...]:
    """Row-major rotation about z by ``angle`` [rad], written out."""
    c, s = math.cos(angle), math.sin(angle)
    return (c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0)


def velocity(rot: tuple[float, ...] = EYE, pos: tuple[float, ...] = ZERO3,
             point: tuple[float, ...] = ZERO3, ref_pos: tuple[float, ...] = ZERO3,
             rot_d: tuple[float, ...] = EYE, omega_d: tuple[float, ...] = ZERO3,
             deflection: tuple[float, ...] = ZERO6,
             rate: tuple[float, ...] = ZERO6) -> tuple[np.ndarray, np.ndarray]:
    linear, angular = task_velocity(rot, pos, point, ref_pos, rot_d, omega_d, deflection,
                                    rate, K_P)
    return np.array(linear), np.array(angular)


def test_all_terms_vanish_at_the_reference() -> None:
    linear, angular = velocity(point=(0.1, 0.2, 0.0))
    np.testing.assert_array_equal(linear, 0.0)
    np.testing.assert_array_equal(angular, 0.0)


def test_frame_position_error_term() -> None:
    """K_p (⁰p_dγ − ⁰p_γ), ⁰p_dγ = ⁰p_r + x̃_p (14): the frame 2 cm short in x, the deflection
    another 1 cm → 5 · 0.03 = 0.15 m/s along x."""
    linear, angular = velocity(pos=(-0.02, 0.0, 0.0), deflection=(0.01, 0, 0, 0, 0, 0))
    np.testing.assert_allclose(linear, [0.15, 0.0, 0.0], atol=1e-15)
    np.testing.assert_array_equal(angular, 0.0)


def test_lever_arm_term_of_the_orientation_error() -> None:
    """K_p (⁰R_d − ⁰R_i) ᶦp_η: the link turned 0.1 rad about z short of R_d, the contact centre
    0.5 m out along the link's x: the centre must move by (R_d − R_i) p, plus the angular term."""
    point = (0.5, 0.0, 0.0)
    linear, angular = velocity(rot=rz(-0.1), point=point)
    expected = K_P * 0.5 * np.array([1.0 - math.cos(0.1), math.sin(0.1), 0.0])
    np.testing.assert_allclose(linear, expected, atol=1e-14)
    np.testing.assert_allclose(angular, [0.0, 0.0, K_P * 0.1], atol=1e-14)


def test_deflection_velocity_feed_forward() -> None:
    """ẋ̃_p passes straight into the linear velocity."""
    linear, angular = velocity(rate=(0.03, -0.02, 0.01, 0.0, 0.0, 0.0))
    np.testing.assert_allclose(linear, [0.03, -0.02, 0.01], atol=1e-15)
    np.testing.assert_array_equal(angular, 0.0)


def test_desired_angular_velocity_moves_the_contact_point() -> None:
    """⁰ω_d × ⁰R_d ᶦp_η: turning at 0.4 rad/s about z with the centre 0.5 m out along x moves it
    at 0.2 m/s along y; ⁰ω_d itself is the angular feed-forward."""
    linear, angular = velocity(point=(0.5, 0.0, 0.0), omega_d=(0.0, 0.0, 0.4))
    np.testing.assert_allclose(linear, [0.0, 0.2, 0.0], atol=1e-15)
    np.testing.assert_allclose(angular, [0.0, 0.0, 0.4], atol=1e-15)


@pytest.mark.parametrize("axis", [0, 1, 2])
def test_orientation_error_term_is_the_rotation_vector(axis: int) -> None:
    """K_p log(⁰R_d ⁰R_iᵀ)^∨: R_d 0.3 rad about an axis from R_i (scipy's rotation, not ours)."""
    phi = np.zeros(3)
    phi[axis] = 0.3
    rot_d = tuple(exp_rotvec(phi).ravel().tolist())
    linear, angular = velocity(rot_d=rot_d)
    np.testing.assert_allclose(angular, K_P * phi, atol=1e-14)
    np.testing.assert_array_equal(linear, 0.0)  # the point is the frame origin


def test_desired_orientation_follows_the_rotational_deflection() -> None:
    """(14): ⁰R_d = exp([x̃_ω]×) ⁰R_r and ⁰ω_d = J_l(x̃_ω) ẋ̃_ω; about one fixed axis J_l is the
    identity on that axis."""
    ref = rz(0.2)
    rot_d, omega = desired_orientation(ref, (0.0, 0.0, 0.3), (0.0, 0.0, 0.7))
    np.testing.assert_allclose(rot_d, rz(0.5), atol=1e-15)
    np.testing.assert_allclose(omega, [0.0, 0.0, 0.7], atol=1e-15)


def test_sliding_term_goes_to_the_control_velocity_and_cancels_in_the_target() -> None:
    """(17), (8): a centre sliding at ᶦṗ_η on the skin — the control velocity adds ⁰R_d ᶦṗ_η;
    the QP target adds ⁰R_d ᶦṗ_η − ⁰R_i ᶦṗ_η, which vanishes while R_d = R_i (the joints need
    not chase the sliding) and not when they differ."""
    rate = (0.0, 0.05, 0.0)
    desired, link = sliding_terms(EYE, EYE, rate)
    np.testing.assert_allclose(desired, rate, atol=1e-15)
    np.testing.assert_allclose(np.subtract(desired, link), 0.0, atol=1e-15)
    desired, link = sliding_terms(rz(math.pi / 2), EYE, rate)
    np.testing.assert_allclose(desired, [-0.05, 0.0, 0.0], atol=1e-15)
    np.testing.assert_allclose(link, rate, atol=1e-15)
