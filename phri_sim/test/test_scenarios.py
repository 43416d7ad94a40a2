"""Every scenario runs (shortened) through the real nodes in lock-step and meets its thresholds.

Thresholds come from honest runs of the current model (docs/phri_sim.md, "Results", which also
gives the full-length numbers), with margin for other seeds:

* centring scores the estimator against the physics: centre within 5 mm (runs: 2 mm), force
  magnitude within 1.5 N (runs: 0.25 N), also with the real skin driver in the loop at the
  paper's fidelity;
* sliding must keep the press on (force ≥ 8 N on average, runs: 9.9 N) and move the robot with
  the slide (largest command ≥ 0.03, runs: 0.09; the bug this guards against gave 0.003);
* whole body: every touched link feels its touch and the robot yields (command ≥ 0.02, runs:
  0.07);
* waltz (30 s: the hold, a closed change — a step away from the forearm and a side step along
  it — and the first bar of a natural turn), on the realistic plant (the base's latency, lag and
  rated accelerations, the arms' RTDE cycle and speedJ ramp, the skin driver's moving average):
  the waist contact held ≥ 95 % and the waist force in 2–25 N ≥ 95 % (runs: 100 %), no force
  spike (peak ≤ 25 N), the partner's position in the robot frame within 5 cm RMS, the partner's
  heading in the robot frame within 10° and the robot turning with the partner (≥ 70 % of the
  partner's turn); the paper's literal set must fail the heading bar by a factor of two (ideal
  plant). Runs (seed 1): default set — held 100 %, band 100 %, peak 12.0 N, position drift
  2.5 cm RMS, heading drift 5.8° max, robot turned 59° of the partner's 62°; the previous
  default set (Λ_rz 0.01, k_η 1000) on the same plant: held 33 %; paper set — heading drift 57°
  max, robot turned 5°, position drift 5.1 cm RMS. (The old
  ``path_rms_error``, world displacements of base origin and torso, reads 24 cm for the default
  set and 8 cm for the paper set: turning with the partner the base orbits the couple's centre, so
  it no longer measures following and is not asserted);
* every scenario: zero limit violations (joint limits, q_dance band, speed limit), and every
  body part of the person and every robot link within its ISO/TS 15066 region's limits (peak ≤
  transient, force held 0.5 s ≤ quasi-static; docs/phri_sim.md, "Body-region limits").

The other runs are on the ideal plant (servos that follow every command at once; the library's
default): their thresholds pin the paper's experiments. The realistic plant's full-length numbers
are the tempo ladder's (``phri ladder``, docs/phri_sim.md "Tempo ladder").
"""

from __future__ import annotations

from typing import Any

import pytest

from phri_sim.evaluation.body_forces import limit_failures
from phri_sim.ros.run_options import RunOptions
from phri_sim.ros.runner import run_scenario
from phri_sim.scenarios.catalogue import WALTZ_DANCE_RANGE, WALTZ_SHORT


def _run(ros_context: Any, name: str, duration: float, **options: Any) -> dict[str, Any]:
    options.setdefault("plant", "ideal")
    metrics = run_scenario(name, RunOptions(duration=duration, seed=1, **options),
                           context=ros_context)
    report = metrics["iso15066"]
    assert "person_waist" in report["person"] and "left_forearm_link" in report["robot_links"]
    failures = limit_failures(report)
    assert not failures and report["ok"], f"ISO/TS 15066 limits exceeded: {failures}"
    return metrics


@pytest.mark.ros
@pytest.mark.parametrize("options", [
    {},
    # The real skin driver in the loop at the paper's fidelity (500 Hz skin, 2 ms physics,
    # moving average of 10): the same thresholds (test_skin_loop.py has the rest).
    {"fidelity": "paper", "skin_driver": True},
], ids=["sim-skin", "paper-skin-driver"])
def test_centring_estimates_match_physics(ros_context: Any, options: dict[str, Any]) -> None:
    m = _run(ros_context, "centring", 11.0, **options)
    link = m["links"]["right_forearm_link"]
    assert m["limit_violations"] == 0
    assert link["peak_force"] > 10.0
    assert link["scored_samples"] > 100
    assert link["center_error_mean"] < 0.005
    assert link["force_error_mean"] < 1.5


@pytest.mark.ros
def test_sliding_keeps_the_press_and_moves_the_robot(ros_context: Any) -> None:
    m = _run(ros_context, "sliding", 10.0)
    link = m["links"]["left_forearm_link"]
    assert m["limit_violations"] == 0
    assert link["touched_share"] > 0.8
    assert link["mean_force_touched"] > 8.0
    assert link["center_error_mean"] < 0.005
    assert m["max_command"] > 0.03


@pytest.mark.ros
def test_whole_body_touches_and_yields(ros_context: Any) -> None:
    m = _run(ros_context, "whole_body", 8.0)
    assert m["limit_violations"] == 0
    assert m["links"]["left_upper_arm_link"]["peak_force"] > 5.0
    assert m["links"]["left_forearm_link"]["peak_force"] > 5.0
    assert m["max_command"] > 0.02


WALTZ_HEADING_MAX = 10.0
"""Bar of the CI waltz on the partner's heading drift in the robot frame [deg] (the following
bar; runs: 5.5°; the paper's literal set: 57°)."""


@pytest.mark.ros
def test_waltz_follows_the_partner_through_the_turn(ros_context: Any) -> None:
    """The short waltz: hold, closed change forward (a step away from the forearm, a side step
    along it), the first bar of a natural turn (the partner turns ≈ 60° clockwise)."""
    m = _run(ros_context, "waltz", WALTZ_SHORT, plant="realistic")
    waltz, following = m["waltz"], m["following"]
    turn = following["turn"]
    assert m["limit_violations"] == 0
    assert waltz["contact_held_share"] >= 0.95
    assert following["band_share"] >= 0.95
    assert waltz["peak_force"] <= 25.0
    assert following["position_drift_rms"] <= 0.05
    assert turn["partner"]["right_deg"] >= 50.0
    assert following["heading_drift_max_deg"] <= WALTZ_HEADING_MAX
    assert turn["robot"]["right_deg"] >= 0.7 * turn["partner"]["right_deg"]
    assert waltz["max_dance_deviation"] <= WALTZ_DANCE_RANGE + 0.01


@pytest.mark.ros
def test_paper_waltz_set_does_not_follow_the_turn(ros_context: Any) -> None:
    """The heading check can fail: the paper's literal set (Sec. VI-B, no lead moment, D = 200 on
    the angular axes) on the same short waltz leaves the partner's turn unfollowed."""
    m = run_scenario("waltz_paper", RunOptions(duration=WALTZ_SHORT, seed=1, plant="ideal"),
                     context=ros_context)
    following = m["following"]
    assert following["turn"]["partner"]["right_deg"] >= 50.0
    assert following["heading_drift_max_deg"] > 2.0 * WALTZ_HEADING_MAX
