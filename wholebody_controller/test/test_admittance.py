"""Admittance (13): exact ZOH discretisation — analytic response, stability for the paper's sets."""

from __future__ import annotations

import math

import numpy as np
import pytest

from wholebody_controller.admittance import admittance_step, discretise, transition
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
