"""One lead through the real nodes: the controller follows a slow forward lead within the bars;
a motionless robot (zero-command stub) fails the same lead by a wide margin. On the ideal plant:
the present controller's behaviour (on the realistic plant it does not hold the waltz's hold:
``phri ladder``, docs/phri_sim.md "Tempo ladder")."""

from __future__ import annotations

from typing import Any

import pytest

from phri_sim.evaluation.following_metrics import Bars
from phri_sim.studies.followability import run_lead
from phri_sim.studies.leads import Lead, LeadTiming, lead_passes

pytestmark = pytest.mark.ros

LEAD = Lead("translate", 0.05, 0.0)
PROFILE = LeadTiming(distance=0.2, intro=0.5, ramp=0.5, outro=1.0).profile(LEAD)
"""0.2 m of lead at 0.05 m/s: twice the 10 cm drift bar for a robot that stands still."""


@pytest.fixture(scope="module")
def runs() -> dict[str, dict[str, Any]]:
    return {c: run_lead(LEAD, PROFILE, controller=c, seed=1, plant="ideal")
            for c in ("node", "stub")}


def test_the_controller_follows_a_slow_forward_lead(runs: dict[str, dict[str, Any]]) -> None:
    m = runs["node"]
    assert lead_passes(m, Bars())["all"], m["following"]["pass"]
    # It trails by a few cm (the contact must slide past the 1 cm margin before it tracks).
    assert m["following"]["travel"]["robot"] > 0.7 * m["following"]["travel"]["partner"]


def test_a_motionless_robot_fails_the_same_lead_by_a_wide_margin(
        runs: dict[str, dict[str, Any]]) -> None:
    f = runs["stub"]["following"]
    assert not lead_passes(runs["stub"], Bars())["all"]
    assert f["travel"]["robot"] < 0.005
    # The partner slides along (or off) the forearm: drift beyond the bar, force far from 10 N.
    assert f["position_drift_max"] > 1.8 * Bars().position_drift_max
    assert f["force_error_rms"] > 2.0 * runs["node"]["following"]["force_error_rms"]


def test_the_tempo_hold_moves_the_base_past_table_ii_within_its_own_limits() -> None:
    """`--tempo` maps run with the `waltz_tempo` set: a partner pushing into the forearm at
    0.3 m/s drives the base beyond Table II's 0.15 (the `waltz` set stops there), each axis
    within its own per-axis bound (0 velocity violations)."""
    push = Lead("translate", 0.3, 90.0)
    profile = LeadTiming(distance=0.15, intro=0.5, ramp=0.3, outro=0.5).profile(push)
    paper_set = run_lead(push, profile, seed=1, plant="ideal")
    tempo_set = run_lead(push, profile, seed=1, base="waltz_tempo", plant="ideal")
    assert paper_set["max_command"] <= 0.15 + 1e-6
    assert tempo_set["max_command"] > 0.2
    assert tempo_set["violations_by_kind"]["velocity"] == 0
