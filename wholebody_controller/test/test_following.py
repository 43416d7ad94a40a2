"""Following a turning lead (:mod:`wholebody_controller.following`): the lead moment (F1) and the
leashed reference (F2) and position (F3), alone and inside the contact task (the link held
still)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation
from wbc_rotations import exp_rotvec

from phri_common.records import ContactState
from wholebody_controller.config import ControllerConfig, LinkTaskConfig
from wholebody_controller.following import (
    FOLD_ANGLE,
    LEASH_ANGLE,
    LEASH_DISTANCE,
    lead_moment,
    leash_position,
    leash_reference,
)
from wholebody_controller.tasks import ContactTask

LINK = "left_forearm_link"


def _mat9(r: np.ndarray) -> tuple[float, ...]:
    return tuple(float(x) for x in r.ravel())


# -- (F1) -----------------------------------------------------------------------------------------
def test_lead_moment_is_the_force_moment_about_the_region_middle() -> None:
    """Two point forces on a straight link, 10 cm apart, pressing along +y: 7 N at x = +0.05 and
    3 N at x = −0.05. Their centroid is at x = (7·0.05 − 3·0.05)/10 = 0.02; about the middle
    x = 0 they have the moment Σ x_k F_k = 0.35 − 0.15 = 0.2 N·m about +z."""
    force = (0.0, 10.0, 0.0)
    tau = lead_moment((0.02, 0.0, 0.0), (-0.06, -0.01, 0.0), (0.06, 0.01, 0.0), force)
    np.testing.assert_allclose(tau, (0.0, 0.0, 0.2), atol=1e-12)


def test_lead_moment_vanishes_for_an_even_press_and_for_a_shifted_region() -> None:
    """An even back (centroid in the middle) gives no lead, wherever the region sits on the link
    (a partner stepping along the link is not a turn)."""
    force = (0.0, 10.0, 0.0)
    for shift in (0.0, 0.07, -0.04):
        tau = lead_moment((shift, 0.0, 0.0), (shift - 0.06, 0.0, 0.0), (shift + 0.06, 0.0, 0.0),
                          force)
        np.testing.assert_allclose(tau, 0.0, atol=1e-12)


def test_lead_moment_equals_numpy_cross_product() -> None:
    rng = np.random.default_rng(3)
    for _ in range(20):
        c, lo, hi, f = (rng.normal(size=3) for _ in range(4))
        expected = np.cross(c - 0.5 * (lo + hi), f)
        np.testing.assert_allclose(lead_moment(tuple(c), tuple(lo), tuple(hi), tuple(f)),
                                   expected, atol=1e-12)


# -- (F2) -----------------------------------------------------------------------------------------
def test_leash_keeps_the_desired_orientation_within_the_leash_and_on_the_same_axis() -> None:
    """A deflection 0.3 rad about z ahead of a link at the reference: the new reference lies
    exactly LEASH_ANGLE from the link about the same axis, the deflection rate turned by J_l."""
    link = exp_rotvec(np.array([0.1, -0.2, 0.4]))
    ref = link.copy()
    deflection = (0.0, 0.0, 0.3)
    rate = (0.0, 0.01, 0.2)
    out = leash_reference(_mat9(ref), deflection, rate, _mat9(link))
    assert out is not None
    new_ref = np.array(out[0]).reshape(3, 3)
    err = Rotation.from_matrix(new_ref @ link.T).as_rotvec()
    np.testing.assert_allclose(err, (0.0, 0.0, LEASH_ANGLE), atol=1e-9)
    # J_l(φ) ẋ for φ about z: the z component is kept, x/y are rotated and scaled.
    phi = 0.3
    jl = np.array([[math.sin(phi) / phi, -(1 - math.cos(phi)) / phi, 0.0],
                   [(1 - math.cos(phi)) / phi, math.sin(phi) / phi, 0.0],
                   [0.0, 0.0, 1.0]])
    np.testing.assert_allclose(out[1], jl @ np.array(rate), atol=1e-12)


def test_leash_leaves_a_close_reference_alone() -> None:
    link = exp_rotvec(np.array([0.0, 0.0, 1.0]))
    assert leash_reference(_mat9(link), (0.0, 0.0, 0.5 * LEASH_ANGLE), (0.0, 0.0, 0.1),
                           _mat9(link)) is None


def test_leash_carries_a_full_turn_past_the_jacobian_singularity() -> None:
    """A sustained lead about z for 2.5 turns, the link following 0.02 rad behind (never pulling
    the leash): folded whole at FOLD_ANGLE, the deflection never exceeds it by more than one
    step, and the desired orientation turns on with the lead (no 2π singularity of J_l)."""
    ref = np.eye(3)
    x = np.zeros(3)
    step = 0.01
    largest = 0.0
    for k in range(1, int(5 * math.pi / step)):
        x = x + np.array([0.0, 0.0, step])
        link = exp_rotvec(np.array([0.0, 0.0, k * step - 0.02]))
        out = leash_reference(_mat9(ref), tuple(x), (0.0, 0.0, 1.0), _mat9(link))
        if out is not None:
            ref, x = np.array(out[0]).reshape(3, 3), np.zeros(3)
        largest = max(largest, float(np.linalg.norm(x)))
    assert largest <= FOLD_ANGLE + step
    total = Rotation.from_matrix(exp_rotvec(x) @ ref).as_rotvec()[2] % (2 * math.pi)
    assert total == pytest.approx((k * step) % (2 * math.pi), abs=0.03)


# -- inside the task ------------------------------------------------------------------------------
def _task(lead: bool) -> ContactTask:
    cfg = LinkTaskConfig(LINK, priority_lock=1.0,  # type: ignore[arg-type]
                         admittance=_gains())
    return ContactTask(cfg, ControllerConfig(links=(cfg,), lead_moment=lead))


def _gains() -> object:
    from wholebody_controller.config import AdmittanceGains

    return AdmittanceGains(inertia=(0.1,) * 5 + (0.01,), damping=(100.0,) * 5 + (0.2,),
                           stiffness=(0.0,) * 6)


def _uneven(k: int) -> ContactState:
    """Link frame = world: the back presses along +y, the centroid 2 cm towards +x of the
    region's middle (the +x end presses harder)."""
    center = np.array([0.02, 0.0, 0.0])
    return ContactState(LINK, k, True, center, np.array([0.0, 10.0, 0.0]), np.zeros(3),
                        np.array([-0.06, -0.01, 0.0]), np.array([0.06, 0.01, 0.0]), 12)


def test_uneven_back_turns_the_link_towards_the_pressing_end_only_with_lead() -> None:
    """10 N with its centroid 2 cm off the middle: 0.2 N·m about +z. With the lead the target
    turns about +z at τ / D = 1 rad/s plus at most K_p ε_ω = 0.25 rad/s of orientation error
    (the leash caps it; Λ/D = 0.05 s, settled after 0.3 s); without it
    (the paper's task) ᶦτ_η = 0 and nothing turns."""
    rot, pos = _mat9(np.eye(3)), [0.0, 0.0, 0.0]
    rates = {}
    for lead in (False, True):
        task = _task(lead)
        out = None
        for k in range(30):
            out = task.step(_uneven(k), rot, pos, 0.0)
        assert out is not None
        rates[lead] = out.target[5]
        if lead:
            assert out.wrench[5] == pytest.approx(0.2, abs=1e-9)
    assert rates[False] == pytest.approx(0.0, abs=1e-9)
    assert 0.95 < rates[True] < 1.0 + 5.0 * LEASH_ANGLE + 0.01


def test_position_leash_rebases_onto_the_leash_end_along_the_lead() -> None:
    """(F3) by hand: a desired point 0.1 m ahead along x (0.04 of it in the deflection) comes
    back to ε_p ahead, on the same line, with the deflection at 0; within ε_p nothing moves."""
    ref, deflection = (0.06, 0.0, 0.0), (0.04, 0.0, 0.0)
    moved = leash_position(ref, deflection, (0.0, 0.0, 0.2), (0.0, 0.0, 0.2))
    assert moved == pytest.approx((LEASH_DISTANCE, 0.0, 0.0), abs=1e-12)
    assert leash_position((0.0, 0.0, 0.0), (0.5 * LEASH_DISTANCE, 0.0, 0.0), (0.0, 0.0, 0.0),
                          (0.0, 0.0, 0.0)) is None
    diagonal = leash_position((0.0, 0.0, 0.0), (0.1, 0.1, 0.0), (0.01, 0.0, 0.0),
                              (0.0, 0.0, 0.0))
    assert diagonal is not None
    lead = np.array(diagonal) + np.array([0.01, 0.0, 0.0])  # the new desired point
    assert np.linalg.norm(lead) == pytest.approx(LEASH_DISTANCE, abs=1e-12)
    assert lead[0] / lead[1] == pytest.approx(0.11 / 0.1, abs=1e-9)


def test_a_link_held_still_under_a_push_does_not_wind_up_its_desired_point() -> None:
    """A 50 N push for 1 s on a link that cannot follow (a robot at its velocity limit), then
    the contact is lost: the paper's task has wound x̃_p up to ≈ 0.5 m (50 N / D = 0.5 m/s for
    1 s) and, its priority locked, asks for K_p · 0.5 m = 2.5 m/s towards it; carried on the
    leash (F3) it asks for at most K_p ε_p = 0.15 m/s, so a lost contact pulls the link on by at
    most ε_p."""
    rot, pos = _mat9(np.eye(3)), [0.0, 0.0, 0.0]
    after_loss = {}
    for lead in (False, True):
        task = _task(lead)
        for k in range(500):  # 1 s at the default 500 Hz
            push = ContactState(LINK, k, True, np.zeros(3), np.array([0.0, 50.0, 0.0]),
                                np.zeros(3), np.array([-0.01, -0.01, 0.0]),
                                np.array([0.01, 0.01, 0.0]), 4)
            task.step(push, rot, pos, 0.0)
        speeds = []
        for k in range(500, 650):
            out = task.step(ContactState(LINK, k, False), rot, pos, 0.0)
            if k >= 510:  # the deflection velocity has decayed (Λ/D = 1 ms)
                speeds.append(float(np.linalg.norm(out.target[0:3])))
        after_loss[lead] = max(speeds)
    assert after_loss[False] > 2.0
    assert after_loss[True] <= 5.0 * LEASH_DISTANCE + 1e-6
