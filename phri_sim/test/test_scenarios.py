"""Every scenario runs (shortened) through the real nodes in lock-step and meets its thresholds.

Thresholds come from the first honest runs (see docs/phri_sim.md, "Results"): centring scores the
estimator against the physics (centre within 5 mm, force within 1.5 N); every scenario must touch
what it means to touch and stay within the joint and velocity limits.
"""

from __future__ import annotations

from typing import Any

import pytest

from phri_sim.runner import run_scenario


def _run(ros_context: Any, name: str, duration: float) -> dict[str, Any]:
    return run_scenario(name, context=ros_context, duration=duration, seed=1)


@pytest.mark.ros
def test_centring_estimates_match_physics(ros_context: Any) -> None:
    m = _run(ros_context, "centring", 11.0)
    link = m["links"]["right_forearm_link"]
    assert m["limit_violations"] == 0
    assert link["peak_force"] > 10.0
    assert link["scored_samples"] > 100
    assert link["center_error_mean"] < 0.005
    assert link["force_error_mean"] < 1.5


@pytest.mark.ros
def test_sliding_touches_and_moves_the_robot(ros_context: Any) -> None:
    m = _run(ros_context, "sliding", 6.0)
    link = m["links"]["left_forearm_link"]
    assert m["limit_violations"] == 0
    assert link["touched_share"] > 0.5
    assert link["peak_force"] > 5.0


@pytest.mark.ros
def test_whole_body_touches_two_links(ros_context: Any) -> None:
    m = _run(ros_context, "whole_body", 8.0)
    assert m["limit_violations"] == 0
    assert m["links"]["left_upper_arm_link"]["peak_force"] > 5.0
    assert m["links"]["left_forearm_link"]["peak_force"] > 5.0


@pytest.mark.ros
@pytest.mark.xfail(reason="known shortfall: the waist contact bounces (stiff impacts, ~60 N "
                   "peaks) and is held well under 95 % of the time; see docs/phri_sim.md",
                   strict=False)
def test_waltz_holds_the_waist(ros_context: Any) -> None:
    m = _run(ros_context, "waltz", 8.0)
    assert m["waltz"]["contact_held_share"] >= 0.95
    assert m["limit_violations"] == 0


@pytest.mark.ros
def test_same_seed_same_run(ros_context: Any) -> None:
    a = run_scenario("centring", context=ros_context, duration=2.0, seed=3)
    b = run_scenario("centring", context=ros_context, duration=2.0, seed=3)
    assert a["links"] == b["links"]
    assert a["max_command"] == b["max_command"]
