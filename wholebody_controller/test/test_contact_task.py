"""One contact centre: track force (10)–(11), priority (15), Algorithm 1's life-cycle, (12) with
the desired force. The link is held still here; closed-loop behaviour is in test_controller.py."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from wbc_rotations import exp_rotvec

from phri_common.records import ContactState
from wholebody_controller.config import LinkTaskConfig
from wholebody_controller.contact_task import Phase, TaskOutput, priority
from wholebody_controller.region import track_force
from wholebody_controller.tasks import ContactTask

LINK = "left_forearm_link"
ROT = exp_rotvec(np.array([0.3, -0.5, 1.1]))
POS = np.array([0.4, 0.2, 1.1])
CENTER = np.array([-0.2, 0.01, 0.05])
HALF = np.array([0.02, 0.015, 0.0])


def contact(force: np.ndarray, center: np.ndarray = CENTER, k: int = 0) -> ContactState:
    return ContactState(LINK, k, True, center.copy(), np.asarray(force, float), np.zeros(3),
                        center - HALF, center + HALF, 12)


def step(task: ContactTask, state: ContactState, rot: np.ndarray, pos: np.ndarray,
         yaw: float) -> TaskOutput:
    """One task step with array inputs (the controller hands floats)."""
    return task.step(state, rot.ravel().tolist(), pos.tolist(), yaw)


def make_task(**kwargs: object) -> ContactTask:
    """A task with Table II's settings (k_η = 200, b = 4, K_p = 5, ψ_thr = 1e-4, 100 Hz) and
    the margin of VI-A.2."""
    return ContactTask(LinkTaskConfig(LINK, **kwargs))  # type: ignore[arg-type]


# -- (10)–(11) ------------------------------------------------------------------------------------
def test_track_force_zero_inside_and_signed_outside() -> None:
    lo, hi = np.array([-0.1, -0.1, -0.1]), np.array([0.1, 0.1, 0.1])
    np.testing.assert_array_equal(track_force(lo / 2, hi / 2, lo, hi), 0.0)
    # Past the +x face by 2 cm → +x; past the −y face by 3 cm → −y.
    mu = track_force(np.array([0.0, -0.13, 0.0]), np.array([0.12, 0.0, 0.0]), lo, hi)
    np.testing.assert_allclose(mu, [0.02, -0.03, 0.0], atol=1e-15)


box = arrays(np.float64, 3, elements=st.floats(-0.2, 0.2))


@given(box, box, box, box)
def test_track_force_vanishes_exactly_when_region_is_inside(a: np.ndarray, b: np.ndarray,
                                                           c: np.ndarray, d: np.ndarray) -> None:
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    dlo, dhi = np.minimum(c, d), np.maximum(c, d)
    mu = np.array(track_force(lo, hi, dlo, dhi))
    inside = bool(np.all(lo >= dlo) and np.all(hi <= dhi))
    assert inside == bool(np.all(mu == 0.0))
    # Per axis, μ points from Ω_d towards the part of Ω that sticks out (when one side does).
    for i in range(3):
        if hi[i] > dhi[i] and lo[i] >= dlo[i]:
            assert mu[i] > 0
        if lo[i] < dlo[i] and hi[i] <= dhi[i]:
            assert mu[i] < 0


# -- (15) -----------------------------------------------------------------------------------------
def test_priority_shape() -> None:
    assert priority(np.zeros(6), 4.0) == 0.0
    # b‖v‖² = ln 3 → (1 − 1/3)/(1 + 1/3) = 1/2.
    v = np.zeros(6)
    v[0] = math.sqrt(math.log(3.0) / 4.0)
    assert priority(v, 4.0) == pytest.approx(0.5, rel=1e-12)
    speeds = np.linspace(0.0, 3.0, 50)
    values = [priority(np.array([s, 0, 0, 0, 0, 0]), 4.0) for s in speeds]
    assert all(np.diff(values) >= 0.0) and values[-1] > 0.999999


# -- Algorithm 1 ---------------------------------------------------------------------------------
def test_no_contact_stays_inactive_at_psi_thr() -> None:
    task = make_task()
    for k in range(50):
        out = step(task, ContactState.no_contact(LINK, k), ROT, POS, 0.0)
        assert out.phase is Phase.INACTIVE
        assert out.psi == 1e-4
        np.testing.assert_array_equal(out.target, 0.0)
        np.testing.assert_array_equal(out.deflection, 0.0)


def test_onset_locks_reference_and_region_with_margin() -> None:
    task = make_task()
    out = step(task, contact(ROT.T @ np.array([0.0, 0.0, -8.0])), ROT, POS, 0.0)
    assert out.phase is Phase.ACTIVATING and out.psi > 1e-4
    ref = task.locked_reference
    region = task.desired_region
    assert ref is not None and region is not None
    np.testing.assert_array_equal(ref[0], ROT)
    np.testing.assert_array_equal(ref[1], POS)
    np.testing.assert_allclose(region[0], CENTER - HALF - 0.01)
    np.testing.assert_allclose(region[1], CENTER + HALF + 0.01)
    # The lock holds while the link moves on.
    step(task, contact(np.zeros(3) + 1.0), ROT, POS + 0.3, 0.0)
    ref2 = task.locked_reference
    assert ref2 is not None
    np.testing.assert_array_equal(ref2[1], POS)


def test_track_force_only_when_region_leaves_desired_region() -> None:
    task = make_task()
    f_local = np.array([0.0, 0.0, -5.0])
    step(task, contact(f_local), ROT, POS, 0.0)
    # Slide 5 mm along link x: within the 1 cm margin → no track force.
    out = step(task, contact(f_local, CENTER + np.array([0.005, 0, 0])), ROT, POS, 0.0)
    np.testing.assert_array_equal(out.track_force, 0.0)
    # Slide 3 cm along link x: 2 cm past x_d⁺ → k_η·0.02 along the link's x axis (world).
    out = step(task, contact(f_local, CENTER + np.array([0.03, 0, 0])), ROT, POS, 0.0)
    np.testing.assert_allclose(out.track_force, 200.0 * 0.02 * ROT[:, 0], atol=1e-12)
    np.testing.assert_allclose(out.wrench[0:3], ROT @ f_local + out.track_force, atol=1e-12)
    # Slide back the other way: 2 cm past x_d⁻ → along −x.
    out = step(task, contact(f_local, CENTER - np.array([0.03, 0, 0])), ROT, POS, 0.0)
    np.testing.assert_allclose(out.track_force, -200.0 * 0.02 * ROT[:, 0], atol=1e-12)


def test_psi_rises_with_deflection_velocity_and_falls_back_after_release() -> None:
    task = make_task()
    phases, psis, speeds = [], [], []
    for k in range(300):
        c = contact(np.array([0.0, 6.0, 0.0]), k=k) if k < 100 else ContactState.no_contact(LINK, k)
        out = step(task, c, ROT, POS, 0.0)
        phases.append(out.phase)
        psis.append(out.psi_raw)
        speeds.append(float(np.linalg.norm(out.deflection_velocity)))
    # Push: ψ grows with ‖ẋ̃‖ (same ordering), and approaches tanh(b (F/D)²/2).
    assert np.all(np.diff(psis[:100]) >= 0.0)
    assert np.all(np.diff(speeds[:100]) >= 0.0)
    assert psis[99] == pytest.approx(math.tanh(0.5 * 4.0 * (6.0 / 40.0) ** 2), rel=1e-3)
    # Release: decays through the damping, then the task resets.
    assert phases[0] is Phase.ACTIVATING
    assert set(phases[1:100]) == {Phase.ACTIVE}
    assert phases[100] is Phase.DEACTIVATING
    assert np.all(np.diff(psis[100:]) <= 0.0)
    assert phases[-1] is Phase.INACTIVE
    first_inactive = phases.index(Phase.INACTIVE)
    assert 100 < first_inactive < 200
    assert task.locked_reference is None
    np.testing.assert_array_equal(task.deflection_velocity, 0.0)
    np.testing.assert_array_equal(task.deflection, 0.0)


def test_push_demands_motion_along_the_push_while_link_is_still() -> None:
    task = make_task()
    force = np.array([3.0, -4.0, 0.0])
    for k in range(20):
        out = step(task, contact(ROT.T @ force, center=np.zeros(3), k=k), ROT, POS, 0.0)
    direction = force / np.linalg.norm(force)
    assert out.target[0:3] @ direction > 0.99 * np.linalg.norm(out.target[0:3])
    np.testing.assert_allclose(out.target[3:6], 0.0, atol=1e-12)


def test_waltz_lock_and_desired_force_in_base_frame() -> None:
    task = make_task(priority_lock=1.0, desired_force=(0.0, -10.0, 0.0))
    yaw = math.pi / 2  # base x → world y, base −y → world +x
    for k in range(30):
        out = step(task, ContactState.no_contact(LINK, k), ROT, POS, yaw)
        assert out.psi == 1.0
        assert out.phase in (Phase.ACTIVATING, Phase.ACTIVE)
    np.testing.assert_allclose(out.wrench, [10.0, 0, 0, 0, 0, 0], atol=1e-12)
    # The link is driven towards the desired force's direction (it presses with 10 N).
    assert out.target[0] > 0.0 and abs(out.target[1]) < 1e-9


def test_user_reference_and_region() -> None:
    ref_rot = exp_rotvec(np.array([0.0, 0.0, 0.2]))
    ref = (*ref_rot.ravel(), 1.0, 2.0, 3.0)
    region = ((-0.5, -0.5, -0.5), (0.5, 0.5, 0.5))
    task = make_task(priority_lock=0.5, reference=ref, desired_region=region)
    out = step(task, contact(np.zeros(3)), ROT, POS, 0.0)
    locked = task.locked_reference
    desired = task.desired_region
    assert locked is not None and desired is not None
    np.testing.assert_array_equal(locked[1], [1.0, 2.0, 3.0])
    np.testing.assert_array_equal(desired[1], [0.5, 0.5, 0.5])
    assert out.psi == 0.5
    # K_p pulls the frame towards the user reference.
    assert out.target[0:3] @ (np.array([1.0, 2.0, 3.0]) - POS) > 0


def test_a_touch_too_light_to_activate_leaves_no_deflection() -> None:
    """Algorithm 1, lines 7/10: while inactive x_d = x_r = x_γ, so x̃ = 0 by (14). A 0.05 N
    touch drives ẋ̃ to F/D = 1.25 mm/s, ψ = tanh(b‖ẋ̃‖²/2) ≈ 3e-6 < ψ_thr: the task never
    activates, and the deflection must not integrate (it would reach ≈ 1 mm in 1 s)."""
    task = make_task()
    for k in range(100):
        out = step(task, contact(np.array([0.0, 0.0, 0.05]), k=k), ROT, POS, 0.0)
        assert out.phase is Phase.INACTIVE
        np.testing.assert_array_equal(out.deflection, 0.0)
    assert np.linalg.norm(out.deflection_velocity) > 1e-3  # the admittance did move


def test_a_sliding_contact_adds_its_rate_to_the_control_velocity_not_the_joint_target() -> None:
    """(17), (20), (8): the contact centre sliding at ᶦṗ_η on the skin — the control velocity
    carries ⁰R_d ᶦṗ_η, the QP target ⁰R_d ᶦṗ_η − ⁰R_i ᶦṗ_η (the joints need not move the centre
    along the skin): control − target = ⁰R_i ᶦṗ_η."""
    task = make_task(priority_lock=1.0)
    rate = np.array([0.05, 0.0, 0.0])  # [m/s] along the link
    for k in range(10):
        out = step(task, contact(np.array([0.0, 0.0, -3.0]), CENTER + k * 0.01 * rate, k), ROT,
                   POS, 0.0)
    np.testing.assert_allclose(out.control_velocity[0:3] - out.target[0:3], ROT @ rate,
                               atol=1e-12)


def test_a_release_drops_the_desired_region_and_the_next_touch_locks_its_own() -> None:
    """Ω_d belongs to one touch (Algorithm 1, line 14): after a release, a touch 10 cm further
    along the link locks a region around itself — no track force from the old one."""
    task = make_task(priority_lock=1.0)
    f = np.array([0.0, 0.0, -4.0])
    step(task, contact(f), ROT, POS, 0.0)
    step(task, ContactState.no_contact(LINK, 1), ROT, POS, 0.0)
    assert task.desired_region is None
    moved = CENTER + np.array([0.1, 0.0, 0.0])
    out = step(task, contact(f, moved, 2), ROT, POS, 0.0)
    region = task.desired_region
    assert region is not None
    np.testing.assert_allclose(region[0], moved - HALF - 0.01)
    np.testing.assert_array_equal(out.track_force, 0.0)
    out = step(task, contact(f, moved, 3), ROT, POS, 0.0)
    np.testing.assert_array_equal(out.track_force, 0.0)
