"""Unscripted leads (phri_sim.studies.unscripted_leads) and the tempo ladder's rungs and runs
(phri_sim.studies.ladder), without running the nodes."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest

from phri_sim.scenarios.catalogue import start_scenario
from phri_sim.studies.ladder import (
    QUICK_LENGTH,
    RungSpec,
    Task,
    build_rung,
    run_ladder,
    rung_names,
)
from phri_sim.studies.unscripted_leads import (
    UNSCRIPTED_LEADS,
    Leg,
    UnscriptedLead,
    unscripted_scenario,
)
from phri_sim.world.simulation import Simulation


@pytest.fixture(scope="module")
def sim() -> Simulation:
    return Simulation()


def _track(sim: Simulation, lead: UnscriptedLead, part: str = "person_torso", dt: float = 0.01
           ) -> tuple[np.ndarray, list[Any]]:
    script = start_scenario(sim, unscripted_scenario(lead))
    ts = np.arange(0.0, lead.duration + 1e-9, dt)
    return ts, [script(float(t))[part] for t in ts]


def test_a_spin_in_place_turns_the_partner_without_moving_it(sim: Simulation) -> None:
    _, targets = _track(sim, UNSCRIPTED_LEADS["spin_left"])
    p = np.array([x.position for x in targets])
    np.testing.assert_allclose(p, np.repeat(p[:1], len(p), axis=0), atol=1e-12)
    assert targets[-1].yaw - targets[0].yaw == pytest.approx(math.pi)


def test_a_couple_turn_rotates_the_hold_about_the_couples_centre(sim: Simulation) -> None:
    """90° left about the midpoint of the robot's start and the partner's: the partner's
    distance to that centre is kept and its bearing turns by 90°."""
    lead = UNSCRIPTED_LEADS["pivot_slow"]
    _, targets = _track(sim, lead)
    start, end = targets[0].position, targets[-1].position
    centre = 0.5 * np.array([start[0], start[1], 0.0])
    r0, r1 = start - centre, end - centre
    assert np.linalg.norm(r1[:2]) == pytest.approx(np.linalg.norm(r0[:2]))
    angle = math.atan2(r0[0] * r1[1] - r0[1] * r1[0], r0[:2] @ r1[:2])
    assert angle == pytest.approx(math.pi / 2)
    assert targets[-1].yaw - targets[0].yaw == pytest.approx(math.pi / 2)


def test_the_box_comes_back_and_every_leg_keeps_its_speed(sim: Simulation) -> None:
    """Four 0.3 m legs at 0.15 m/s: back at the start; the target velocity is the rate of the
    target position; full speed 0.15 m/s; the partner stands at the end (outro)."""
    lead = UNSCRIPTED_LEADS["box"]
    ts, targets = _track(sim, lead, dt=0.001)
    p = np.array([x.position for x in targets])
    v = np.array([x.velocity for x in targets])
    np.testing.assert_allclose(p[-1], p[0], atol=1e-9)
    assert np.max(np.linalg.norm(v, axis=1)) == pytest.approx(0.15)
    fd = np.gradient(p, 0.001, axis=0)
    assert np.max(np.abs(fd[1:-1] - v[1:-1])) < 1e-3
    assert np.all(v[ts > lead.duration - lead.outro + 1e-9] == 0.0)


def test_backing_away_moves_the_hold_away_from_the_forearm(sim: Simulation) -> None:
    _, targets = _track(sim, UNSCRIPTED_LEADS["back_away"], part="person_left_hand")
    moved = targets[-1].position - targets[0].position
    np.testing.assert_allclose(moved, [0.0, -0.5, 0.0], atol=1e-9)


def test_lead_legs_are_validated() -> None:
    with pytest.raises(ValueError, match="kind"):
        Leg("hop", 0.1, 0.1)
    with pytest.raises(ValueError, match="amount"):
        Leg("turn", 0.5, 0.0)
    with pytest.raises(ValueError, match="speed"):
        Leg("translate", -0.1, 0.3)
    turn = Leg("turn", -1.0, math.pi)
    assert turn.profile().distance(turn.profile().duration)[0] == pytest.approx(math.pi)


def test_the_ladder_rungs_and_what_their_quick_form_runs() -> None:
    names = rung_names()
    assert names[:4] == ["x1", "x2", "x4", "tempo"]
    assert {n for n in names if n.startswith("lead:")} == {f"lead:{k}" for k in UNSCRIPTED_LEADS}
    x1, x4 = build_rung(RungSpec("x1")), build_rung(RungSpec("x4", full=True))
    assert x1.duration == QUICK_LENGTH and x1.scenario.bars == "waltz"
    assert x4.duration == pytest.approx(x4.scenario.duration) and x4.scenario.bars == "tempo"
    assert build_rung(RungSpec("tempo")).scenario.name == "waltz_tempo"
    assert build_rung(RungSpec("sway2")).scenario.partner["sway"] == 2
    lead = build_rung(RungSpec("lead:box"))
    assert lead.duration == UNSCRIPTED_LEADS["box"].duration
    custom = build_rung(RungSpec("x2", parameters={"k_eta": 5.0}))
    assert custom.scenario.controller_parameters == {"k_eta": 5.0}
    for bad in ("x0", "sway", "lead:moonwalk", "waltz"):
        with pytest.raises(ValueError, match="rung"):
            build_rung(RungSpec(bad))


def test_run_ladder_runs_each_rung_per_plant_and_the_baseline_once() -> None:
    seen: list[Task] = []

    def fake(task: Task) -> dict[str, Any]:
        seen.append(task)
        return {"rung": task.rung.name, "plant": task.plant, "controller": task.controller}

    out = run_ladder([RungSpec("x1"), RungSpec("lead:box")], ("realistic", "ideal"), jobs=1,
                     runner=fake)
    assert len(seen) == 6  # 2 rungs × 2 plants + 2 baselines
    assert sorted((t.rung.name, t.plant) for t in seen if t.controller == "stub") == [
        ("lead:box", "realistic"), ("x1", "realistic")]
    assert [r["rung"] for r in out["runs"]][:4] == ["x1", "lead:box", "x1", "lead:box"]
    assert seen[0].rung.name == "x1" and seen[0].controller == "node"  # longest first
    with pytest.raises(ValueError, match="rung"):
        run_ladder([RungSpec("x-1")], runner=fake)
