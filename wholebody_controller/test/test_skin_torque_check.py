"""The skin against the joints' external-torque estimate (skin_torque_check) on synthetic data:
a skin whose gain is far off, and a skin silent while the joints feel a contact, are verdicts
after hold_time; a skin that agrees within noise is not."""

from __future__ import annotations

import numpy as np
import pytest

from wholebody_controller.skin_torque_check import (
    GAIN_OFF,
    SKIN_FROZEN,
    SKIN_SILENT,
    SkinTorqueCheck,
    TorqueCheckConfig,
    expected_joint_torques,
    gain_ratio,
)

RNG = np.random.default_rng(4)
JACOBIANS = [RNG.normal(0.0, 0.5, (6, 6)) for _ in range(3)]
WRENCHES = [np.array([0.0, -10.0, 0.0, 0.0, 0.0, 0.3]), np.zeros(6), np.zeros(6)]
TRUE = expected_joint_torques(JACOBIANS, WRENCHES)


def run(check: SkinTorqueCheck, skin_gain: float, in_contact: bool = True,
        periods: int = 100, backing_off: bool = False,
        extra: np.ndarray | None = None) -> list[tuple[str, float]]:
    """``periods`` cycles at 100 Hz of a skin that reads ``skin_gain`` × the true contact, the
    joints measuring the truth (plus an ``extra`` contact no skin feels) with 0.1 N·m of noise;
    the verdicts with their times."""
    verdicts = []
    for k in range(periods):
        measured = TRUE + RNG.normal(0.0, 0.1, TRUE.shape)
        if extra is not None:
            measured = measured + extra
        kind, message = check.update(skin_gain * TRUE, measured, in_contact, k * 0.01,
                                     backing_off)
        if kind:
            assert message
            verdicts.append((kind, k * 0.01))
    return verdicts


def test_expected_torques_are_the_transposed_jacobians_of_the_wrenches() -> None:
    np.testing.assert_allclose(TRUE, JACOBIANS[0].T @ WRENCHES[0])
    assert gain_ratio(3.0 * TRUE, TRUE) == pytest.approx(1.0 / 3.0)
    assert np.linalg.norm(TRUE) > 3.0  # the synthetic contact is large enough to be judged


def test_a_skin_that_agrees_gives_no_verdict() -> None:
    assert run(SkinTorqueCheck(), 1.0) == []
    assert run(SkinTorqueCheck(), 1.5) == []  # within the allowed ratio


@pytest.mark.parametrize("gain", [3.0, 0.3])
def test_a_gain_far_off_is_a_verdict_after_hold_time(gain: float) -> None:
    verdicts = run(SkinTorqueCheck(TorqueCheckConfig(hold_time=0.3)), gain)
    assert verdicts and verdicts[0][0] == GAIN_OFF
    assert verdicts[0][1] == pytest.approx(0.3)


def test_a_silent_skin_while_backing_off_does_not_relieve_is_a_verdict() -> None:
    config = TorqueCheckConfig(silent_torque=2.0, silent_hold_time=0.5)
    verdicts = run(SkinTorqueCheck(config), 0.0, in_contact=False, backing_off=True)
    assert verdicts and verdicts[0] == (SKIN_SILENT, pytest.approx(0.5))
    # No contact anywhere: nothing to say.
    check = SkinTorqueCheck()
    assert check.update(np.zeros(6), RNG.normal(0.0, 0.1, 6), False, 0.0, True) == ("", "")


def test_a_silent_skin_is_left_to_the_unsensed_guard_until_it_backs_off() -> None:
    """An unsensed contact looks like a silent skin: while the guard only slows (or nothing
    stops), it is the guard's — slowing, backing off and resuming — not a latched stop."""
    config = TorqueCheckConfig(silent_torque=2.0, silent_hold_time=0.5)
    assert run(SkinTorqueCheck(config), 0.0, in_contact=False, backing_off=False) == []


def test_another_contact_beside_a_right_skin_is_not_a_gain() -> None:
    """A skin that reads right while another, unsensed contact loads other joints: the scaled
    skin explains the measured torques badly, so the gain is not judged (the guard's case)."""
    across = RNG.normal(0.0, 1.0, 6)
    across -= (across @ TRUE) / (TRUE @ TRUE) * TRUE  # loads the joints another way
    extra = 1.5 * TRUE + 3.0 * float(np.linalg.norm(TRUE)) * across / np.linalg.norm(across)
    assert run(SkinTorqueCheck(TorqueCheckConfig(max_residual=0.5)), 1.0, extra=extra) == []
    assert run(SkinTorqueCheck(TorqueCheckConfig(max_residual=1.0)), 1.0, extra=extra)


def test_a_short_disagreement_is_forgotten() -> None:
    check = SkinTorqueCheck(TorqueCheckConfig(hold_time=0.3))
    assert run(check, 3.0, periods=20) == []  # 0.2 s
    assert run(check, 1.0, periods=5) == []
    assert run(check, 3.0, periods=20) == []  # the clock restarted


def test_refusals() -> None:
    with pytest.raises(ValueError, match="one size"):
        SkinTorqueCheck().update(np.zeros(6), np.zeros(5), True, 0.0, False)
    with pytest.raises(ValueError, match="skin_max_gain_ratio"):
        TorqueCheckConfig(max_gain_ratio=0.5)
    with pytest.raises(ValueError, match="skin_silent_hold_time"):
        TorqueCheckConfig(silent_hold_time=-1.0)


READING = (10.0, (0.1, 0.0, 0.05))
"""The skin link's contact: 10 N at its centre [m]."""


def still_run(check: SkinTorqueCheck, truth: object, skin_follows: bool, seconds: float = 60.0,
              extra: np.ndarray | None = None) -> list[tuple[str, float]]:
    """``seconds`` at 100 Hz of one skin link in contact; the true contact is ``truth(t)`` ×
    the synthetic one; the skin reads it (``skin_follows``) or replays the reading of t = 0
    (a frozen driver), each with the skin's noise (0.2 % of the force); the joints measure the
    truth (plus ``extra``) with 0.1 N·m of noise. The verdicts with their times."""
    verdicts = []
    for k in range(round(seconds * 100)):
        t = k * 0.01
        scale = truth(t) if callable(truth) else 1.0
        read = scale if skin_follows else 1.0
        force = READING[0] * read * (1.0 + 0.002 * RNG.standard_normal())
        measured = scale * TRUE + RNG.normal(0.0, 0.1, TRUE.shape)
        if extra is not None:
            measured = measured + extra
        kind, _ = check.update(read * TRUE, measured, True, t, False,
                               {"link": (force, READING[1], read * TRUE)})
        if kind:
            verdicts.append((kind, t))
    return verdicts


def test_a_still_hold_the_joints_agree_with_is_no_verdict_for_60_s() -> None:
    """A partner holding still on a well-followed link: the skin reads still for a minute,
    and the joints agree with it — stillness alone is no evidence."""
    check = SkinTorqueCheck()
    assert still_run(check, None, skin_follows=True) == []
    assert check.still_time == pytest.approx(59.99)  # still the whole minute


def ramp(t: float) -> float:
    """The contact grows by 60 % over 1 s from 2 s on (within the gain check's band)."""
    return 1.0 + 0.6 * min(max(t - 2.0, 0.0), 1.0)


def test_a_frozen_skin_whose_contact_changes_is_a_verdict_the_gain_check_misses() -> None:
    """A replayed frame while the contact grows by 60 %: the gain (1.6) stays within the
    allowed [1/2, 2], the frozen check finds it once the change reaches skin_frozen_torque."""
    config = TorqueCheckConfig(frozen_torque=3.0, frozen_hold_time=0.3)
    verdicts = still_run(SkinTorqueCheck(config), ramp, skin_follows=False, seconds=6.0)
    assert verdicts and verdicts[0][0] == SKIN_FROZEN
    reach = 2.0 + 3.0 / (0.6 * float(np.linalg.norm(TRUE)))  # when ‖Δu‖ reaches 3 N·m
    assert reach + 0.3 - 0.05 <= verdicts[0][1] <= reach + 0.3 + 0.1
    # The same change read by a live skin is no verdict (it is not still).
    assert still_run(SkinTorqueCheck(config), ramp, skin_follows=True, seconds=6.0) == []


def test_a_frozen_skin_whose_contact_lets_go_is_a_verdict() -> None:
    """The partner lets go while the skin replays its contact: the joints feel nothing, too
    little for the gain to be judged; the frozen check sees the skin's whole contact vanish."""
    def release(t: float) -> float:
        return 0.0 if t >= 2.0 else 1.0
    verdicts = still_run(SkinTorqueCheck(), release, skin_follows=False, seconds=4.0)
    assert verdicts and verdicts[0] == (SKIN_FROZEN, pytest.approx(2.3))


def test_an_unsensed_contact_beside_a_still_skin_is_not_frozen() -> None:
    """A still, right skin while another contact loads the joints another way: the change is
    not along the skin's contact (the guard's case, not a frozen skin)."""
    across = RNG.normal(0.0, 1.0, 6)
    across -= (across @ TRUE) / (TRUE @ TRUE) * TRUE
    extra = 3.0 * float(np.linalg.norm(TRUE)) * across / np.linalg.norm(across)
    check = SkinTorqueCheck(TorqueCheckConfig(max_gain_ratio=100.0))
    verdicts = []
    for k in range(400):
        t = k * 0.01
        measured = TRUE + (extra if t >= 1.0 else 0.0) + RNG.normal(0.0, 0.1, TRUE.shape)
        kind, _ = check.update(TRUE, measured, True, t, False, {"link": (*READING, TRUE)})
        if kind:
            verdicts.append(kind)
    assert SKIN_FROZEN not in verdicts and check.still_change > 3.0
