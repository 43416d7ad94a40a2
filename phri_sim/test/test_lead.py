"""Lead scenarios and the followability search (phri_sim.studies.leads), without running the
nodes."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest

from phri_sim.evaluation.following_metrics import Bars
from phri_sim.scenarios.catalogue import SCENARIOS, Partner, start_scenario, with_partner
from phri_sim.studies.leads import (
    FULL_TIMING,
    Lead,
    LeadTiming,
    Profile,
    followability_map,
    lead_passes,
    lead_scenario,
)
from phri_sim.world.simulation import Simulation


def test_profile_distance_is_the_integral_of_its_speed() -> None:
    """s(t) ends at ramp + cruise (two half ramps and the cruise) and ṡ integrates to s."""
    p = Profile(intro=1.0, ramp=0.8, cruise=2.0, outro=0.5)
    ts = np.linspace(0.0, p.duration, 4001)
    s = np.array([p.distance(t)[0] for t in ts])
    rate = np.array([p.distance(t)[1] for t in ts])
    assert s[-1] == pytest.approx(0.8 + 2.0)
    integral = np.concatenate([[0.0], np.cumsum(0.5 * (rate[1:] + rate[:-1]) * np.diff(ts))])
    np.testing.assert_allclose(s, integral, atol=1e-5)
    assert rate.max() == pytest.approx(1.0)
    assert p.distance(0.99)[0] == 0.0


SHORT_PROFILE = Profile(intro=0.5, ramp=0.5, cruise=1.0, outro=0.0)


def test_every_lead_covers_the_same_amount_at_any_speed() -> None:
    """0.30 m of translation or 90° of turn, whatever the speed; short ramps at high speed."""
    for v in (0.025, 0.1, 0.5):
        p = FULL_TIMING.profile(Lead("translate", v, 45.0))
        assert v * p.distance(p.duration)[0] == pytest.approx(0.30)
        assert p.ramp <= p.cruise + 1e-12
    p = FULL_TIMING.profile(Lead("turn", -0.3))
    assert 0.3 * p.distance(p.duration)[0] == pytest.approx(math.pi / 2)
    assert p.duration == pytest.approx(1.0 + (math.pi / 2) / 0.3 + 1.0 + 1.0)
    with pytest.raises(ValueError, match="distance"):
        LeadTiming(distance=0.0)


@pytest.fixture(scope="module")
def sim() -> Simulation:
    return Simulation()


def _torso(script: Any, t: float) -> Any:
    return next(iter(script(t).values()))


def test_a_translation_moves_the_hold_rigidly_at_the_lead_speed(sim: Simulation) -> None:
    """Heading 90° (to the robot's left) at 0.1 m/s: every part moves +y by 0.1·s(t), velocity
    0.1 m/s in the cruise, heading unchanged."""
    lead = Lead("translate", 0.1, 90.0)
    sc = lead_scenario(lead, SHORT_PROFILE)
    script = start_scenario(sim, sc)
    hold = with_partner(SCENARIOS["waltz"], Partner(hand=False)).make_script(sim)(0.0)
    t = SHORT_PROFILE.intro + SHORT_PROFILE.ramp + 0.5
    now = script(t)
    shift = 0.1 * SHORT_PROFILE.distance(t)[0]
    for name, target in hold.items():
        np.testing.assert_allclose(now[name].position - target.position, [0.0, shift, 0.0],
                                   atol=1e-12)
        np.testing.assert_allclose(now[name].velocity - target.velocity, [0.0, 0.1, 0.0],
                                   atol=1e-12)
        assert now[name].yaw == pytest.approx(target.yaw)
    assert sc.name not in SCENARIOS


def test_a_turn_rotates_the_hold_about_the_couples_centre(sim: Simulation) -> None:
    """A right turn at 0.3 rad/s: the torso keeps its distance to the couple's centre, its yaw
    changes by −0.3·s(t), and its target velocity is tangential (ω × r)."""
    lead = Lead("turn", -0.3)
    script = lead_scenario(lead, SHORT_PROFILE).make_script(sim)
    p0 = _torso(script, 0.0)
    centre = np.array([0.5 * p0.position[0], 0.5 * p0.position[1], p0.position[2]])
    t = SHORT_PROFILE.duration
    now = _torso(script, t - 1.0)
    theta = -0.3 * SHORT_PROFILE.distance(t - 1.0)[0]
    assert np.linalg.norm(now.position - centre) == pytest.approx(
        np.linalg.norm(p0.position - centre))
    assert now.yaw - p0.yaw == pytest.approx(theta)
    r = now.position - centre
    assert float(now.velocity @ r) == pytest.approx(0.0, abs=1e-9)
    assert np.linalg.norm(now.velocity[:2]) == pytest.approx(0.3 * np.linalg.norm(r[:2]))
    assert math.copysign(1.0, float(np.cross(r, now.velocity)[2])) == -1.0


def _fake_run(limits: dict[str, float]) -> Any:
    """A 'robot' that follows every lead up to a known speed per direction and then drifts."""
    def run(lead: Lead) -> dict[str, Any]:
        key = f"{lead.kind}{lead.heading_deg:g}" if lead.kind == "translate" else (
            "left" if lead.speed > 0 else "right")
        ok = abs(lead.speed) <= limits[key] + 1e-12
        return {"following": {"band_share": 1.0, "heading_drift_max_deg": 1.0,
                              "position_drift_rms": 0.01 if ok else 0.2,
                              "position_drift_max": 0.02 if ok else 0.3,
                              "force_error_rms": 1.0,
                              "peak_force": {"person": {"waist": 12.0}, "robot": {}}},
                "iso15066": {"ok": True}, "limit_violations": 0}
    return run


def test_the_map_finds_the_fastest_lead_followed_per_direction() -> None:
    limits = {"translate0": 0.15, "translate90": 0.0, "left": 0.3, "right": 0.05}
    out = followability_map(_fake_run(limits), Bars(), headings=(0.0, 90.0),
                            speeds=(0.05, 0.1, 0.15, 0.2), turn_rates=(0.05, 0.3, 1.0))
    fastest = {row["heading_deg"]: row["fastest_followed"] for row in out["translate"]}
    assert fastest == {0.0: 0.15, 90.0: 0.0}
    assert len(out["translate"][0]["cells"]) == 4  # 0.2 tried and failed
    assert len(out["translate"][1]["cells"]) == 1  # the slowest failed: search stops
    turns = {row["direction"]: row["fastest_followed"] for row in out["turn"]}
    assert turns == {"left": 0.3, "right": 0.05}


def test_a_lead_fails_on_force_limits_and_violations() -> None:
    good = _fake_run({"translate0": 1.0})(Lead("translate", 0.1, 0.0))
    assert lead_passes(good, Bars())["all"]
    assert not lead_passes({**good, "limit_violations": 3}, Bars())["all"]
    assert not lead_passes({**good, "iso15066": {"ok": False}}, Bars())["all"]


def test_bad_leads_are_refused_with_the_parameter() -> None:
    with pytest.raises(ValueError, match="speed"):
        Lead("translate", -0.1)
    with pytest.raises(ValueError, match="kind"):
        Lead("spin", 0.1)
    with pytest.raises(ValueError, match="ramp"):
        Profile(ramp=0.0)
