"""The partner as a person (phri_sim.scenarios.catalogue.Partner and
phri_sim.scenarios.partner_variability): tempo scale, seeded sway, hesitations and deviations,
the other hand resting on the arm."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from phri_sim.scenarios.catalogue import (
    HAND_REST_FORCE,
    SCENARIOS,
    Partner,
    start_scenario,
    waltz_duration,
    with_partner,
)
from phri_sim.scenarios.partner_variability import Hesitations, Sway, human_variability
from phri_sim.scenarios.waltz_choreography import TEMPOS
from phri_sim.world.simulation import Simulation


@pytest.fixture(scope="module")
def sim() -> Simulation:
    return Simulation()


def _torso_track(sim: Simulation, partner: Partner, until: float, dt: float = 0.01
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(times, torso target positions (N, 3), their velocities) of the waltz danced by
    ``partner``."""
    script = start_scenario(sim, with_partner(SCENARIOS["waltz"], partner))
    ts = np.arange(0.0, until, dt)
    targets = [script(float(t))["person_torso"] for t in ts]
    return ts, np.array([p.position for p in targets]), np.array([p.velocity for p in targets])


def test_tempo_scale_compresses_the_routine_in_time_with_the_same_steps(sim: Simulation) -> None:
    """×2: the routine takes half as long (intro and outro unchanged), the same path at twice
    the speed."""
    routine = SCENARIOS["waltz"].duration - 5.0
    assert waltz_duration("paper", Partner(tempo_scale=2.0)) == pytest.approx(5.0 + routine / 2)
    t1, p1, v1 = _torso_track(sim, Partner(hand=False), 40.0)
    t2, p2, v2 = _torso_track(sim, Partner(tempo_scale=2.0, hand=False), 21.0)
    k = np.searchsorted(t1, 2.0 + 2.0 * (t2[t2 >= 2.0] - 2.0) - 1e-9)
    np.testing.assert_allclose(p2[t2 >= 2.0], p1[k], atol=1e-9)
    assert np.max(np.linalg.norm(v2, axis=1)) == pytest.approx(
        2.0 * np.max(np.linalg.norm(v1, axis=1)), rel=0.02)


def test_the_same_sway_seed_gives_the_same_partner_and_another_seed_another(
        sim: Simulation) -> None:
    a = _torso_track(sim, Partner(sway=3, hand=False), 20.0)[1]
    b = _torso_track(sim, Partner(sway=3, hand=False), 20.0)[1]
    c = _torso_track(sim, Partner(sway=4, hand=False), 20.0)[1]
    np.testing.assert_array_equal(a, b)
    assert np.max(np.abs(a - c)) > 1e-3


def test_postural_sway_stays_within_its_amplitude_and_band(sim: Simulation) -> None:
    """During the standing intro (before any step or hesitation) the torso target moves only
    by the sway: at most 1 cm per axis of the dancer's frame and 2° of heading."""
    script = start_scenario(sim, with_partner(SCENARIOS["waltz"], Partner(sway=5, hand=False)))
    still = start_scenario(sim, with_partner(SCENARIOS["waltz"], Partner(hand=False)))
    ts = np.arange(0.0, 2.0, 0.005)
    dx = np.array([script(t)["person_torso"].position - still(t)["person_torso"].position
                   for t in ts])
    dyaw = np.array([script(t)["person_torso"].yaw - still(t)["person_torso"].yaw for t in ts])
    assert np.max(np.abs(dx[:, :2])) <= math.sqrt(2.0) * 0.01 + 1e-12
    assert np.max(np.abs(dx[:, :2])) > 0.003
    assert np.max(np.abs(dyaw)) <= math.radians(2.0) + 1e-12
    draw = human_variability(Sway(5), 60, (2.0, 170.0)).sway
    assert np.all((draw.freqs >= 0.3) & (draw.freqs <= 1.5))


def test_script_velocities_are_the_rate_of_the_positions_with_sway_and_hesitations(
        sim: Simulation) -> None:
    """The damper is fed the true rate: finite differences of the target agree with its
    velocity (through hesitations and the sway), except at the instant the routine starts,
    where the choreography's first step sets off with the spline's end slope."""
    t, p, v = _torso_track(sim, Partner(sway=2, tempo_scale=4.0, hand=False), 30.0, dt=0.001)
    fd = np.gradient(p, 0.001, axis=0)
    inner = (t > 0.0) & (t < t[-1]) & (np.abs(t - 2.0) > 0.0015)
    assert np.max(np.abs(fd[inner, :2] - v[inner, :2])) < 2e-3


def test_a_hesitation_halts_the_clock_smoothly_and_delays_the_dance_by_its_length() -> None:
    h = Hesitations((10.0,), (0.5,))
    ts = np.linspace(0.0, 20.0, 20001)
    clock = np.array([h.clock(t) for t in ts])
    assert np.all(np.diff(clock[:, 0]) >= 0.0)
    assert clock[:, 1].min() == pytest.approx(0.0, abs=1e-6)  # the dance stands
    assert clock[-1, 0] == pytest.approx(20.0 - 0.5)
    np.testing.assert_allclose(np.gradient(clock[:, 0], ts)[1:-1], clock[1:-1, 1], atol=1e-3)
    var = human_variability(Sway(1), 30, (2.0, 100.0))
    gaps = np.diff(var.hesitations.starts)
    assert np.all(gaps >= 8.0) and var.hesitations.total > 0.0
    assert np.all(np.abs(var.step_factors - 1.0) <= 0.1 + 1e-12)


def test_the_partners_other_hand_rests_lightly_on_the_right_forearm() -> None:
    """The default waltz: 2 s into the hold (robot held still) the right hand presses the right
    forearm's skin with about 3 N, a contact of its own apart from the waist on the left
    forearm (10 N); without the hand the right forearm is untouched."""
    for partner, expected in ((Partner(), HAND_REST_FORCE), (Partner(hand=False), 0.0)):
        sim = Simulation()
        script = start_scenario(sim, with_partner(SCENARIOS["waltz"], partner))
        for _ in range(400):
            for part, target in script(sim.time).items():
                sim.set_target(part, target)
            sim.step(2)
        truth = sim.ground_truth()
        assert truth["right_forearm_link"].normal_force == pytest.approx(expected, abs=0.6)
        assert truth["left_forearm_link"].normal_force == pytest.approx(10.0, abs=2.5)


def test_partner_options_are_refused_outside_the_waltz_and_out_of_range() -> None:
    with pytest.raises(ValueError, match="waltz only"):
        with_partner(SCENARIOS["centring"], Partner(tempo_scale=2.0))
    with pytest.raises(ValueError, match="tempo scale"):
        Partner(tempo_scale=0.0)
    with pytest.raises(ValueError, match="sway seed"):
        Partner(sway=-1)
    fast = with_partner(SCENARIOS["waltz"], Partner(tempo_scale=2.0))
    assert fast.bars == "tempo" and fast.partner["tempo_scale"] == 2.0
    assert with_partner(SCENARIOS["waltz"], Partner(sway=1)).bars == "sway"
    assert with_partner(SCENARIOS["waltz_tempo"], Partner()).partner["tempo"] == "tempo"
    assert dataclasses.replace(TEMPOS["paper"]).beat == 5.5
