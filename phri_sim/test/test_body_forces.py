"""Body-region force limits (phri_sim.evaluation.body_forces): the ISO/TS 15066 reading of a force
series, the body-part mapping and the forces read from the physics."""

from __future__ import annotations

import numpy as np
import pytest

from phri_common.iso15066 import BODY_REGIONS
from phri_sim.evaluation.body_forces import (
    PERSON_PART_REGIONS,
    ForceLimitTracker,
    PersonRobotForces,
    limit_report,
    part_region,
)
from phri_sim.scenarios.catalogue import SCENARIOS, start_scenario
from phri_sim.world.simulation import SimConfig, Simulation
from phri_sim.world.skin_footprint import SkinConfig

DT = 0.005


def _feed(tracker: ForceLimitTracker, profile: list[tuple[float, float]], end: float) -> None:
    """Samples every DT up to ``end`` of a piecewise-constant force: (start time, force)."""
    for k in range(round(end / DT) + 1):
        t = k * DT
        f = [force for start, force in profile if t >= start - 1e-12][-1]
        tracker.add(t, {"part": f})


def test_short_impact_is_transient_a_held_push_is_sustained() -> None:
    tracker = ForceLimitTracker()
    # 300 N for 0.4 s (an impact), later 150 N held for 0.6 s, over a 5 N background.
    _feed(tracker, [(0.0, 5.0), (1.0, 300.0), (1.4, 5.0), (3.0, 150.0), (3.6, 5.0)], 5.0)
    assert tracker.peak("part") == 300.0
    assert tracker.sustained("part") == 150.0


def test_a_push_just_shorter_than_the_window_is_not_sustained() -> None:
    tracker = ForceLimitTracker()
    _feed(tracker, [(0.0, 5.0), (1.0, 200.0), (1.49, 5.0)], 3.0)  # 0.49 s above
    assert tracker.sustained("part") == 5.0
    longer = ForceLimitTracker()
    _feed(longer, [(0.0, 5.0), (1.0, 200.0), (1.505, 5.0)], 3.0)  # 0.505 s above
    assert longer.sustained("part") == 200.0


def test_names_listed_but_never_touched_read_zero() -> None:
    tracker = ForceLimitTracker()
    for k in range(200):
        tracker.add(k * DT, {"a": 3.0} if k < 150 else {}, ("a", "b"))
    assert tracker.peak("b") == 0.0 and tracker.sustained("b") == 0.0
    assert tracker.peak("a") == 3.0 and tracker.sustained("a") == 3.0
    assert tracker.peak("unknown") == 0.0


def _sustained_by_definition(times: np.ndarray, f: np.ndarray, window: float) -> float:
    """max over t ≥ t_0 + window of min{F(s) : t − window ≤ s ≤ t}, sample by sample."""
    out = 0.0
    for t in times:
        if t - times[0] >= window - 1e-9:
            inside = (times >= t - window - 1e-9) & (times <= t)
            out = max(out, float(f[inside].min()))
    return out


def test_intermittent_contacts_match_the_definition() -> None:
    """Contacts that come and go (the tracker skips names at rest between them): peak and
    sustained force of every name as their definitions give them on the whole series."""
    rng = np.random.default_rng(7)
    n, names = 1200, ("a", "b", "c")
    times = np.arange(n) * DT
    series = {}
    for name in names:
        on = np.zeros(n, bool)
        k = 0
        while k < n:  # alternating rests and pushes of 1 to 200 samples
            length = int(rng.integers(1, 200))
            on[k:k + length] = rng.random() < 0.5
            k += length
        series[name] = np.where(on, rng.uniform(1.0, 100.0, n).round(1), 0.0)
    # A push held exactly one window (101 samples) after a rest, and one a sample shorter.
    names = (*names, "held", "short")
    series["held"], series["short"] = np.zeros(n), np.zeros(n)
    series["held"][300:401], series["short"][700:800] = 50.0, 80.0
    tracker = ForceLimitTracker()
    for k, t in enumerate(times):
        tracker.add(float(t), {m: float(series[m][k]) for m in names if series[m][k] > 0.0},
                    names)
    assert tracker.sustained("held") == 50.0 and tracker.sustained("short") == 0.0
    for name in names:
        assert tracker.peak(name) == series[name].max()
        assert tracker.sustained(name) == _sustained_by_definition(times, series[name], 0.5)


def test_limit_report_flags_each_limit() -> None:
    abdomen = BODY_REGIONS["abdomen"]  # 110 N quasi-static, 220 N transient
    assert limit_report(abdomen, 219.0, 109.0)["ok"] is True
    assert limit_report(abdomen, 221.0, 50.0)["ok"] is False
    assert limit_report(abdomen, 150.0, 111.0)["ok"] is False
    row = limit_report(abdomen, 1.0, 1.0)
    assert row["quasi_static_limit"] == 110.0 and row["transient_limit"] == 220.0
    assert limit_report(None, 500.0, 500.0)["ok"] is True


def test_every_person_part_has_a_region_and_unknown_parts_are_refused() -> None:
    sim = Simulation()
    reader = PersonRobotForces(sim.model, sim.person.geom_part)
    assert set(reader.parts) == set(PERSON_PART_REGIONS)
    assert part_region("person_waist").name == "abdomen"
    assert part_region("person_left_hand").name == "hand_finger"
    assert "left_forearm_link" in reader.links and "base_link" in reader.links
    assert not any(link.startswith("person") for link in reader.links)
    with pytest.raises(KeyError, match=r"person_knee.*mapped"):
        part_region("person_knee")


def test_waist_force_matches_the_physics_of_the_waltz_hold() -> None:
    """At the settled waltz hold the waist presses the left forearm with the 10 N preload: the
    force read per part and per link equals the skin link's ground truth (normal force, an
    independent sum in sim_skins), and nothing else touches."""
    sim = Simulation(SimConfig(skin=SkinConfig(noise_std=0.0)))
    start_scenario(sim, SCENARIOS["waltz"])
    sim.step(10)
    parts, links, pairs = PersonRobotForces(sim.model, sim.person.geom_part).read(sim.data)
    truth = sim.ground_truth()["left_forearm_link"].normal_force
    assert truth == pytest.approx(10.0, rel=0.2)
    assert set(parts) == {"person_waist"} and set(links) == {"left_forearm_link"}
    assert parts["person_waist"] == pytest.approx(truth, rel=0.05)
    assert links["left_forearm_link"] == parts["person_waist"]
    assert pairs == {("person_waist", "left_forearm_link")}
    assert np.isfinite(parts["person_waist"])
