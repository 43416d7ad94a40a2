"""Admittance (13): exact ZOH discretisation — analytic response, stability for the paper's sets."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from wholebody_controller.admittance import (
    admittance_step,
    dead_zone,
    discretise,
    transition,
    turn_gate,
)
from wholebody_controller.config import CONTACT_TRACKING, WALTZ, WHOLE_BODY, diag6

PAPER_SETS = {
    "centring": (0.5 * np.eye(6), 40.0 * np.eye(6), np.zeros((6, 6))),
    "tracking": (diag6(CONTACT_TRACKING.inertia), diag6(CONTACT_TRACKING.damping),
                 np.zeros((6, 6))),
    "whole_body": (diag6(WHOLE_BODY.inertia), diag6(WHOLE_BODY.damping),
                   diag6(WHOLE_BODY.stiffness)),
    "waltz": (diag6(WALTZ.inertia), diag6(WALTZ.damping), np.zeros((6, 6))),
    "brief_0.1_200": (0.1 * np.eye(6), 200.0 * np.eye(6), np.zeros((6, 6))),
}


class Admittance:
    """x̃, ẋ̃ of (13) in a state row of 12, stepped by the step's own :func:`admittance_step`."""

    def __init__(self, lam: np.ndarray, d: np.ndarray, k: np.ndarray, dt: float) -> None:
        self.phi_gamma = transition(lam, d, k, dt)
        self.state = np.zeros(12)

    def step(self, wrench: np.ndarray) -> None:
        admittance_step(self.state, self.phi_gamma, tuple(float(w) for w in wrench))

    @property
    def deflection(self) -> np.ndarray:
        return self.state[0:6]

    @property
    def deflection_velocity(self) -> np.ndarray:
        return self.state[6:12]


def test_constant_force_matches_the_continuous_solution() -> None:
    # Mass–damper under a step force F: v(t) = F/D (1 − e^{−t D/Λ}),
    # x(t) = F/D (t − Λ/D (1 − e^{−t D/Λ})). Exact at the samples for a held force.
    lam, d, f, dt = 0.5, 40.0, 7.0, 0.01
    adm = Admittance(lam * np.eye(6), d * np.eye(6), np.zeros((6, 6)), dt)
    wrench = np.array([f, 0, 0, 0, 0, 0])
    for _ in range(37):
        adm.step(wrench)
    t, tau = 37 * dt, lam / d
    assert adm.deflection_velocity[0] == pytest.approx(f / d * (1 - math.exp(-t / tau)), rel=1e-10)
    assert adm.deflection[0] == pytest.approx(f / d * (t - tau * (1 - math.exp(-t / tau))),
                                              rel=1e-10)
    np.testing.assert_allclose(adm.deflection[1:], 0.0, atol=1e-15)


def test_spring_settles_at_force_over_stiffness() -> None:
    adm = Admittance(0.5 * np.eye(6), 60.0 * np.eye(6), 40.0 * np.eye(6), 0.002)
    wrench = np.array([0, 0, 8.0, 0, 0, 2.0])
    for _ in range(20000):  # 40 s ≫ time constants
        adm.step(wrench)
    np.testing.assert_allclose(adm.deflection, wrench / 40.0, atol=1e-9)
    np.testing.assert_allclose(adm.deflection_velocity, 0.0, atol=1e-9)


@pytest.mark.parametrize("name", sorted(PAPER_SETS))
@pytest.mark.parametrize("rate", [100.0, 200.0, 500.0])
def test_stable_for_every_paper_set_and_rate(name: str, rate: float) -> None:
    lam, d, k = PAPER_SETS[name]
    phi, _ = discretise(lam, d, k, 1.0 / rate)
    assert np.max(np.abs(np.linalg.eigvals(phi))) <= 1.0 + 1e-12
    # Free response from an initial velocity decays (never grows).
    adm = Admittance(lam, d, k, 1.0 / rate)
    adm.step(np.full(6, 50.0))
    v0 = np.linalg.norm(adm.deflection_velocity)
    for _ in range(int(15 * rate)):  # 15 s: the slowest pole (whole-body set) is 0.67 1/s
        adm.step(np.zeros(6))
        assert np.linalg.norm(adm.deflection_velocity) <= v0 * (1 + 1e-12)
    assert np.linalg.norm(adm.deflection_velocity) < 1e-3 * v0


def test_explicit_euler_would_be_unstable_for_the_waltz_set() -> None:
    # The reason for the exact scheme: D/Λ·dt = 20 > 2 at 100 Hz.
    lam, d, dt = 0.1, 200.0, 0.01
    assert abs(1 - d / lam * dt) > 1.0
    adm = Admittance(lam * np.eye(6), d * np.eye(6), np.zeros((6, 6)), dt)
    for _ in range(100):
        adm.step(np.array([10.0, 0, 0, 0, 0, 0]))
    assert adm.deflection_velocity[0] == pytest.approx(10.0 / d, rel=1e-9)


def test_rejects_bad_period() -> None:
    with pytest.raises(ValueError, match="period"):
        discretise(np.eye(6), np.eye(6), np.zeros((6, 6)), 0.0)


def test_dead_zone_is_zero_inside_its_band_and_shrinks_by_it_outside() -> None:
    """(D1) on analytic cases: a 3-4-0 N force (5 N) with a 2 N band keeps its direction at 3 N;
    a force inside the band and a torque inside its own give exact zeros; bands of 0 change
    nothing."""
    out = dead_zone((3.0, 4.0, 0.0, 0.0, 0.0, 0.05), 2.0, 0.1)
    assert out == pytest.approx((1.8, 2.4, 0.0, 0.0, 0.0, 0.0))
    assert dead_zone((0.3, -0.4, 0.0, 0.0, 0.0, 0.0), 0.5, 0.0) == (0.0,) * 6
    w = (1.0, -2.0, 0.5, 0.01, -0.02, 0.03)
    assert dead_zone(w, 0.0, 0.0) == pytest.approx(w)


@settings(max_examples=200)
@given(st.lists(st.floats(-50.0, 50.0), min_size=6, max_size=6),
       st.floats(0.0, 5.0), st.floats(0.0, 0.5))
def test_dead_zone_is_a_continuous_shrink_by_at_most_its_band(
        wrench: list[float], force_band: float, torque_band: float) -> None:
    """(D1) on random wrenches: each part loses at most its band, never grows, never turns
    (w'·w ≥ 0 per part), and is exactly zero when its size is within the band."""
    out = np.array(dead_zone(tuple(wrench), force_band, torque_band))
    w = np.array(wrench)
    for part, band in ((slice(0, 3), force_band), (slice(3, 6), torque_band)):
        size, shrunk = np.linalg.norm(w[part]), np.linalg.norm(out[part])
        assert np.linalg.norm(w[part] - out[part]) <= band + 1e-9
        assert shrunk <= size + 1e-12 and float(w[part] @ out[part]) >= -1e-12
        if size <= band:
            assert shrunk == 0.0


def test_turn_gate_keeps_the_torque_up_to_its_force_and_fades_it_to_nothing_at_1_5_times() -> None:
    """(T1) on analytic cases with F_t = 20 N: the torque is whole at a 20 N contact, half at
    25 N, nothing from 30 N on; the force part is never touched; F_t = 0 changes nothing."""
    w = (1.0, -2.0, 0.5, 0.2, -0.4, 0.6)
    assert turn_gate(w, 20.0, 20.0) == w
    assert turn_gate(w, 25.0, 20.0) == pytest.approx((1.0, -2.0, 0.5, 0.1, -0.2, 0.3))
    assert turn_gate(w, 30.0, 20.0) == (1.0, -2.0, 0.5, 0.0, -0.0, 0.0)
    assert turn_gate(w, 250.0, 20.0)[3:] == (0.0, -0.0, 0.0)
    assert turn_gate(w, 250.0, 0.0) == w


@settings(max_examples=200)
@given(st.lists(st.floats(-50.0, 50.0), min_size=6, max_size=6),
       st.floats(0.0, 500.0), st.floats(0.0, 100.0), st.floats(0.0, 100.0))
def test_turn_gate_never_grows_or_turns_the_torque_and_fades_with_force(
        wrench: list[float], force: float, limit: float, more: float) -> None:
    """(T1) on random wrenches: the force part unchanged, the torque part scaled by one factor
    in [0, 1] that does not grow with a larger contact force."""
    out = np.array(turn_gate(tuple(wrench), force, limit))
    w = np.array(wrench)
    assert np.array_equal(out[:3], w[:3])
    size = np.linalg.norm(w[3:])
    if size > 0.0:
        gain = float(np.linalg.norm(out[3:])) / size
        assert 0.0 <= gain <= 1.0 + 1e-12
        assert np.allclose(out[3:], gain * w[3:])
        later = np.linalg.norm(np.array(turn_gate(tuple(wrench), force + more, limit))[3:])
        assert later <= gain * size + 1e-9
