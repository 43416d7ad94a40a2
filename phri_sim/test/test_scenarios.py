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
* waltz (the hold, the first forward step and the step away from the robot): the waist contact
  held ≥ 95 % (runs: 100 %), no force spike (peak ≤ 25 N, runs: 16.7 N), the base follows the
  torso (RMS path error ≤ 5 cm, runs: 1.5–2.4 cm), arms within q_dance ± 0.1 (runs: 0.04);
* every scenario: zero limit violations (joint limits, q_dance band, speed limit), and every
  body part of the person and every robot link within its ISO/TS 15066 region's limits (peak ≤
  transient, force held 0.5 s ≤ quasi-static; docs/phri_sim.md, "Body-region limits").
"""

from __future__ import annotations

from typing import Any

import pytest

from phri_sim.body_forces import limit_failures
from phri_sim.runner import run_scenario


def _run(ros_context: Any, name: str, duration: float, **options: Any) -> dict[str, Any]:
    metrics = run_scenario(name, context=ros_context, duration=duration, seed=1, **options)
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


@pytest.mark.ros
def test_waltz_holds_the_waist_and_follows(ros_context: Any) -> None:
    m = _run(ros_context, "waltz", 16.0)
    waltz = m["waltz"]
    assert m["limit_violations"] == 0
    assert waltz["contact_held_share"] >= 0.95
    assert waltz["peak_force"] <= 25.0
    assert 5.0 <= waltz["mean_force"] <= 15.0
    assert waltz["path_rms_error"] <= 0.05
    assert waltz["base_travel"] > 0.5 * waltz["torso_travel"]
    assert waltz["max_dance_deviation"] <= 0.1 + 0.01


@pytest.mark.ros
def test_same_seed_same_run(ros_context: Any) -> None:
    a = run_scenario("centring", context=ros_context, duration=2.0, seed=3)
    b = run_scenario("centring", context=ros_context, duration=2.0, seed=3)
    assert a["links"] == b["links"]
    assert a["max_command"] == b["max_command"]
