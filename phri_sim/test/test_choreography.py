"""The waltz choreography (phri_sim.scenarios.waltz_choreography): figures, turn, travel and each
tempo's limits."""

from __future__ import annotations

import math

import numpy as np
import pytest

from phri_sim.scenarios.waltz_choreography import (
    TEMPOS,
    Beat,
    Choreography,
    Tempo,
    keyframes,
    routine,
    waltz_choreography,
)

DT = 0.01


def _turns(headings: np.ndarray) -> tuple[float, float]:
    """(accumulated clockwise, counter-clockwise turn) [rad] of a sampled heading."""
    d = np.diff(headings)
    return float(-d[d < 0].sum()), float(d[d > 0].sum())


@pytest.mark.parametrize("name", sorted(TEMPOS))
def test_routine_turns_a_full_turn_each_way_and_travels_three_metres(name: str) -> None:
    """The figure bars: ≥ 360° of turn each way and ≥ 3 m of torso travel, at both
    tempos, in 3/4 time (a whole number of bars)."""
    tempo = TEMPOS[name]
    beats = routine(tempo)
    assert len(beats) % 3 == 0
    _, p, psi, _ = waltz_choreography(name).sample(DT)
    cw, ccw = _turns(psi)
    assert cw >= 2 * math.pi - 1e-6 and ccw >= 2 * math.pi - 1e-6
    travel = float(np.sum(np.linalg.norm(np.diff(p, axis=0), axis=1)))
    assert travel >= 3.0


def test_paper_tempo_is_within_table_ii_velocity_limits() -> None:
    """`paper`: the torso's planar speed and turn rate stay below Table II's 0.15 m/s and
    0.15 rad/s (finite differences of the sampled pose, independent of the interpolant's
    derivative)."""
    _, p, psi, _ = waltz_choreography("paper").sample(DT)
    speed = np.linalg.norm(np.diff(p, axis=0), axis=1) / DT
    rate = np.abs(np.diff(psi)) / DT
    assert speed.max() < 0.15 and rate.max() < 0.15


def test_tempo_is_a_real_slow_waltz() -> None:
    """`tempo`: a bar in 2 s, steps ≥ 0.3 m, 90° per bar in the turns; the whole routine in
    about half a minute."""
    tempo = TEMPOS["tempo"]
    assert 3 * tempo.beat == pytest.approx(2.0)
    assert tempo.step >= 0.3
    assert tempo.turn_per_bar == pytest.approx(0.5 * math.pi)
    chor = waltz_choreography("tempo")
    assert chor.duration < 60.0


def test_keyframes_walk_in_the_partner_frame() -> None:
    """A step forward after a quarter turn to the left goes along +y in the start frame: the
    step's direction is the heading at mid-beat."""
    points, headings = keyframes([Beat(0.0, 0.0, 0.5 * math.pi), Beat(0.3, 0.0, 0.0),
                                  Beat(0.0, 0.2, 0.0)])
    np.testing.assert_allclose(points[2], [0.0, 0.3], atol=1e-12)
    np.testing.assert_allclose(points[3], [-0.2, 0.3], atol=1e-12)
    assert headings[-1] == pytest.approx(0.5 * math.pi)


def test_pose_starts_and_ends_at_rest_and_passes_the_keyframes() -> None:
    chor = Choreography([Beat(0.2, 0.0), Beat(0.0, 0.1, 0.3)], beat_time=2.0, intro=1.0,
                        outro=1.0)
    p0, psi0, v0, w0 = chor.pose(0.0)
    np.testing.assert_array_equal(p0, 0.0)
    assert psi0 == 0.0 and not v0.any() and w0 == 0.0
    p, psi, _, _ = chor.pose(3.0)  # end of the first beat
    np.testing.assert_allclose(p, [0.2, 0.0], atol=1e-12)
    p, psi, v, w = chor.pose(chor.duration)  # the side step taken at mid-beat heading 0.15
    np.testing.assert_allclose(p, [0.2 - 0.1 * math.sin(0.15), 0.1 * math.cos(0.15)],
                               atol=1e-12)
    assert psi == pytest.approx(0.3) and not v.any() and w == 0.0


def test_velocity_is_the_derivative_of_the_position() -> None:
    chor = waltz_choreography("paper")
    for t in (8.0, 31.7, 60.2, 101.3):
        p1, psi1, _, _ = chor.pose(t - 1e-4)
        p2, psi2, v, w = chor.pose(t + 1e-4)
        np.testing.assert_allclose(v, (p2 - p1) / 2e-4, atol=1e-5)
        assert w == pytest.approx((psi2 - psi1) / 2e-4, abs=1e-5)


def test_bad_input_names_the_field() -> None:
    with pytest.raises(ValueError, match="beat"):
        Tempo("x", beat=0.0, step=0.2, side=0.1, turn_per_bar=1.0)
    with pytest.raises(ValueError, match="unknown; allowed: paper, tempo"):
        waltz_choreography("quickstep")
    with pytest.raises(ValueError, match="beats"):
        Choreography([], 1.0)
