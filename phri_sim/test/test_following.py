"""Following metrics (phri_sim.evaluation.following_metrics) on analytic pose sequences: known
drift, turn, lag."""

from __future__ import annotations

import math

import numpy as np
import pytest

from phri_sim.evaluation.following_metrics import (
    Bars,
    FollowingSeries,
    accumulated_turn,
    check_bars,
    contact_losses,
    drift,
    following_summary,
    force_tracking,
    relative_pose,
    travel,
)
from phri_sim.evaluation.partner_feel import rate_lag

DT = 0.01
T = np.arange(0.0, 10.0, DT)


def _partner_walk_and_turn() -> np.ndarray:
    """A partner 0.6 m in front of the origin walks 1 m along +x at 0.1 m/s and turns +90°."""
    x = 0.6 + 0.1 * T
    y = np.zeros_like(T)
    yaw = np.radians(9.0) * T
    return np.column_stack([x, y, yaw])


def test_relative_pose_of_a_known_configuration() -> None:
    """Base at (1, 2) facing +y, partner at (1, 3) facing −x: 1 m straight ahead, turned +90°."""
    rel = relative_pose(np.array([[1.0, 2.0, math.pi / 2]]), np.array([[1.0, 3.0, math.pi]]))
    np.testing.assert_allclose(rel, [[1.0, 0.0, math.pi / 2]], atol=1e-12)


def test_a_robot_that_copies_the_partner_has_zero_drift() -> None:
    """The base moves rigidly with the partner (same displacement and rotation about the
    partner): the partner's pose in the base frame never changes."""
    partner = _partner_walk_and_turn()
    offset = np.array([-0.6, 0.2])  # base relative to partner, in the partner's frame
    c, s = np.cos(partner[:, 2]), np.sin(partner[:, 2])
    base = np.column_stack([partner[:, 0] + c * offset[0] - s * offset[1],
                            partner[:, 1] + s * offset[0] + c * offset[1], partner[:, 2]])
    d = drift(relative_pose(base, partner))
    assert d["position_drift_max"] < 1e-9
    assert d["heading_drift_max_deg"] < 1e-9


def test_a_fixed_robot_sees_the_partners_own_motion_as_drift() -> None:
    """Base fixed at the origin: position drift = the partner's displacement (1 m at the end,
    RMS of a linear ramp = 1/√3 m), heading drift = its turn (90° max)."""
    partner = _partner_walk_and_turn()
    d = drift(relative_pose(np.zeros((T.size, 3)), partner))
    assert d["position_drift_max"] == pytest.approx(0.999, abs=1e-3)
    assert d["position_drift_rms"] == pytest.approx(1.0 / math.sqrt(3.0), rel=2e-3)
    assert d["heading_drift_max_deg"] == pytest.approx(89.91, abs=1e-2)


def test_drift_counts_from_the_start_index() -> None:
    partner = _partner_walk_and_turn()
    d = drift(relative_pose(np.zeros((T.size, 3)), partner), start=500)
    assert d["position_drift_max"] == pytest.approx(0.499, abs=1e-3)


def test_accumulated_turn_in_each_direction_through_the_wrap() -> None:
    """+400° then −200°: the wrapped heading crosses ±180° several times."""
    yaw = np.concatenate([np.radians(np.linspace(0.0, 400.0, 801)),
                          np.radians(np.linspace(400.0, 200.0, 401))[1:]])
    turn = accumulated_turn(np.asarray(np.angle(np.exp(1j * yaw))))
    assert turn["left_deg"] == pytest.approx(400.0, abs=1e-6)
    assert turn["right_deg"] == pytest.approx(200.0, abs=1e-6)
    assert turn["net_deg"] == pytest.approx(200.0, abs=1e-6)


def test_lag_recovers_a_known_delay() -> None:
    """The follower repeats the leader's smooth velocity profile 0.37 s later (between samples:
    the parabola through the correlation peak)."""
    def path(t: np.ndarray) -> np.ndarray:
        return np.column_stack([np.sin(0.7 * t) + 0.3 * np.sin(2.1 * t), np.cos(0.5 * t)])

    tau, rho = rate_lag(T, path(T), path(T - 0.37), max_lag=2.0)
    assert tau == pytest.approx(0.37, abs=DT / 2)
    assert rho > 0.9
    tau, _ = rate_lag(T, path(T - 0.373), path(T), max_lag=2.0)
    assert tau == pytest.approx(-0.373, abs=DT / 5)


def test_turning_lag_of_a_robot_that_turns_later() -> None:
    """The robot stays put but turns with the partner's heading profile 0.5 s later."""
    partner = _partner_walk_and_turn()
    partner[:, 2] = np.sin(0.6 * T) + 0.5 * np.sin(1.3 * T)
    base = np.zeros_like(partner)
    base[:, 2] = np.sin(0.6 * (T - 0.5)) + 0.5 * np.sin(1.3 * (T - 0.5))
    out = following_summary(FollowingSeries(T, base, partner, np.full(T.size, 10.0),
                                            np.ones(T.size, bool)), 10.0)
    assert out["turning_lag"] == pytest.approx(0.5, abs=DT / 2)
    assert out["translation_lag"] is None


def test_lag_is_none_for_a_robot_that_stands_still() -> None:
    tau, rho = rate_lag(T, _partner_walk_and_turn()[:, :2], np.zeros((T.size, 2)), max_lag=2.0)
    assert tau is None and rho == 0.0


def test_lag_is_none_for_a_robot_that_hardly_moves() -> None:
    """A follower copying the leader at 1 % of its amplitude (a motionless robot nudged on its
    servos) has no lag, however well the shapes correlate."""
    walk = _partner_walk_and_turn()[:, :2]
    tau, rho = rate_lag(T, walk, 0.01 * walk, max_lag=2.0)
    assert tau is None and rho > 0.9


def test_lag_is_none_for_unrelated_motion() -> None:
    """A follower moving across the leader's path (orthogonal velocity) has no lag."""
    walk = np.column_stack([0.1 * T, np.zeros_like(T)])
    tau, rho = rate_lag(T, walk, walk[:, ::-1], max_lag=2.0)
    assert tau is None and rho < 0.5


def test_lag_of_an_exact_copy_is_zero_even_at_constant_velocity() -> None:
    """An exact copy correlates best at no shift."""
    walk = _partner_walk_and_turn()[:, :2]
    tau, rho = rate_lag(T, walk, walk - 0.6, max_lag=2.0)
    assert tau == pytest.approx(0.0, abs=1e-9) and rho == pytest.approx(1.0)


def test_force_band_share_and_error() -> None:
    """Half the samples at 10 N (error 0, in band), a quarter at 30 N, a quarter at 0 N."""
    f = np.concatenate([np.full(50, 10.0), np.full(25, 30.0), np.zeros(25)])
    out = force_tracking(f, 10.0, (2.0, 25.0))
    assert out["band_share"] == pytest.approx(0.5)
    assert out["force_error_max"] == pytest.approx(20.0)
    assert out["force_error_rms"] == pytest.approx(math.sqrt((25 * 400 + 25 * 100) / 100))


def test_contact_losses_and_time_to_regain() -> None:
    t = np.arange(10) * 0.5
    on = np.array([1, 1, 0, 0, 1, 1, 0, 1, 0, 0], dtype=bool)
    out = contact_losses(t, on)
    assert out["count"] == 3
    assert out["time_to_regain_max"] == pytest.approx(1.0)  # lost at 1.0, back at 2.0
    assert out["time_lost"] == pytest.approx(1.0 + 0.5 + 0.5)
    assert out["unregained"] is True


def test_travel_of_a_square() -> None:
    sq = np.array([[0, 0], [1, 0], [1, 1], [0, 1], [0, 0]], dtype=float)
    assert travel(sq) == pytest.approx(4.0)


def _series(base: np.ndarray, force: float) -> FollowingSeries:
    partner = _partner_walk_and_turn()
    return FollowingSeries(T, base, partner, np.full(T.size, force), np.ones(T.size, bool))


def test_a_motionless_robot_fails_the_bars_by_a_wide_margin() -> None:
    """Against a partner who walks 1 m and turns 90°, a fixed base fails drift by 10× and 9×."""
    out = following_summary(_series(np.zeros((T.size, 3)), 10.0), 10.0)
    assert not out["pass"]["all"]
    assert out["position_drift_max"] > 10 * (Bars().position_drift_max or 0.0) - 0.01
    assert out["heading_drift_max_deg"] > 8 * Bars().heading_drift_max_deg
    assert out["translation_lag"] is None


def test_a_copying_robot_passes_and_excess_force_fails() -> None:
    partner = _partner_walk_and_turn()
    base = partner - np.array([0.6, 0.0, 0.0])
    base[:, :2] = partner[:, :2] - 0.6 * np.column_stack([np.cos(partner[:, 2]),
                                                          np.sin(partner[:, 2])])
    out = following_summary(_series(base, 10.0), 10.0,
                            peak_forces={"person": {"person_waist": 12.0}, "robot": {}})
    assert out["pass"]["all"], out["pass"]
    assert out["turn"]["robot"]["left_deg"] == pytest.approx(out["turn"]["partner"]["left_deg"])
    hard = dict(out, peak_force={"person": {"person_waist": 41.0}})
    assert not check_bars(hard, Bars())["partner_force"]


def test_bad_input_names_the_parameter() -> None:
    with pytest.raises(ValueError, match="band_low"):
        Bars(band_low=30.0)
    with pytest.raises(ValueError, match="partner poses"):
        relative_pose(np.zeros((3, 3)), np.zeros((3, 2)))


def _orbiting_couple(n: int = 200) -> tuple[np.ndarray, np.ndarray]:
    """A couple turning 270° counter-clockwise about a point between them (as in a natural
    turn): the base at radius 0.7 facing the tangent, the partner at radius 0.1 opposite it,
    facing the tangent the other way; both turn with the couple."""
    phi = np.linspace(0.0, 1.5 * math.pi, n)
    base = np.column_stack([0.7 * np.cos(phi), 0.7 * np.sin(phi), phi + 0.5 * math.pi])
    partner = np.column_stack([0.1 * np.cos(phi + math.pi), 0.1 * np.sin(phi + math.pi),
                               phi - 0.5 * math.pi])
    return base, partner


def test_a_couple_turning_together_has_no_drift() -> None:
    """The base travels 3.3 m on its orbit, but the partner stays put in its frame."""
    base, partner = _orbiting_couple()
    out = drift(relative_pose(base, partner))
    assert out["position_drift_max"] == pytest.approx(0.0, abs=1e-12)
    assert out["heading_drift_max_deg"] == pytest.approx(0.0, abs=1e-9)
    assert accumulated_turn(base[:, 2])["left_deg"] == pytest.approx(270.0)
    assert accumulated_turn(partner[:, 2])["left_deg"] == pytest.approx(270.0)


def test_a_still_robot_beside_a_turning_partner_sees_the_circle() -> None:
    """The partner orbits 0.1 m about the origin; a robot standing at (0.7, 0) sees its
    position drift up to the circle's diameter and its heading drift through 180°."""
    _, partner = _orbiting_couple()
    base = np.tile([0.7, 0.0, 0.0], (partner.shape[0], 1))
    out = drift(relative_pose(base, partner))
    assert out["position_drift_max"] == pytest.approx(0.2, abs=1e-4)
    assert out["heading_drift_max_deg"] == pytest.approx(180.0, abs=1.0)
