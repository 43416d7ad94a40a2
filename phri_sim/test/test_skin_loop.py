"""The real skin driver in the simulated loop at the paper's fidelity (docs/phri_sim.md,
"Skin sensor model and the skin driver in the loop"): 500 Hz frames of the protocol through the
driver, determinism, and that handing the estimator only each period's newest frame changes
nothing downstream. (The scenario thresholds with the driver: test_scenarios.py.)"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import pytest

from phri_sim.ros.run_options import RunOptions
from phri_sim.ros.runner import ScenarioRun, run_scenario
from phri_sim.scenarios.catalogue import scenario_named

TIMING = ("wall_time", "real_time_factor", "cpu_time", "real_time_factor_cpu")


def _outcome(metrics: dict[str, Any]) -> dict[str, Any]:
    return {k: v for k, v in metrics.items() if k not in TIMING}


@pytest.mark.ros
def test_paper_fidelity_sends_every_500_hz_frame_through_the_driver(ros_context: Any) -> None:
    run = ScenarioRun(scenario_named("centring"),
                      RunOptions(duration=2.0, seed=2, fidelity="paper", skin_driver=True),
                      context=ros_context)
    try:
        metrics = run.run()
        link = run.bridge.skin_link
        assert link is not None
        assert run.bridge.sim.dt == pytest.approx(0.002)
        board = link.sensors["right_forearm"].board_id
        counters = link.stream.counters[board]
        parser = link.stream.parser.stats
    finally:
        run.close()
    # While the patch is touched every 2 ms sample of it is a frame (untouched, it is read every
    # 100 ms), after the 100 tare frames. At 100 Hz it would be a fifth of that.
    touched = metrics["links"]["right_forearm_link"]["touched_share"] * 2.0
    assert touched > 0.5
    assert counters.taring == 100
    assert counters.sequence.frames >= 100 + 0.95 * 500 * touched
    assert counters.sequence.dropped == 0 and parser.errors == 0 and parser.resyncs == 0
    assert metrics["links"]["right_forearm_link"]["scored_samples"] > 20
    assert metrics["skin_driver"] and metrics["fidelity"] == "paper"


@pytest.mark.ros
def test_same_seed_same_run_with_the_driver_in_the_loop(ros_context: Any) -> None:
    options = RunOptions(duration=2.0, fidelity="paper", skin_driver=True)
    a = run_scenario("centring", replace(options, seed=3), context=ros_context)
    b = run_scenario("centring", replace(options, seed=3), context=ros_context)
    c = run_scenario("centring", replace(options, seed=4), context=ros_context)
    assert _outcome(a) == _outcome(b)
    link = "right_forearm_link"
    assert a["links"][link]["scored_samples"] > 20
    assert a["links"][link]["force_error_mean"] != c["links"][link]["force_error_mean"]


@pytest.mark.ros
def test_newest_frame_per_period_changes_nothing_downstream(ros_context: Any) -> None:
    """The paper fidelity hands the estimator one frame per control period: the estimator keeps
    nothing between frames and the controller uses the newest estimate, so publishing all five
    500 Hz frames gives the same run."""
    options = RunOptions(duration=2.0, seed=5, fidelity="paper", skin_driver=True)
    every = run_scenario("centring", replace(options, taxel_publish_rate_hz=0.0),
                         context=ros_context)
    newest = run_scenario("centring", options, context=ros_context)
    assert every["links"]["right_forearm_link"]["scored_samples"] > 20
    assert _outcome(every) == _outcome(newest)


@pytest.mark.ros
def test_direct_sensor_handoff_gives_the_run_of_the_topics(ros_context: Any) -> None:
    """The lock-step runner hands the taxel arrays to contact estimation and the joint states
    and odometry to the controller directly (no serialisation, no DDS): the nodes must see
    exactly what they decode from the topics (float32 taxel columns), so the run is the same,
    number for number; the topics are then published only while someone subscribes."""
    options = RunOptions(duration=2.0, seed=5, fidelity="paper")
    topics = run_scenario("centring", replace(options, sensor_transport="topics"),
                          context=ros_context)
    run = ScenarioRun(scenario_named("centring"), options, context=ros_context)
    try:
        direct = run.run()
        pubs = run.bridge.skin_pubs
        subscribed = [pubs[p].get_subscription_count() for p in run.bridge.sim.patches]
        subscribed += [run.bridge.joint_pub.get_subscription_count(),
                       run.bridge.odom_pub.get_subscription_count()]
    finally:
        run.close()
    assert direct["links"]["right_forearm_link"]["scored_samples"] > 20
    assert (direct["sensor_transport"], topics["sensor_transport"]) == ("direct", "topics")
    same = {"sensor_transport": ""}
    assert {**_outcome(direct), **same} == {**_outcome(topics), **same}
    assert subscribed == [0, 0, 0, 0, 0]
