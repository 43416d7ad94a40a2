"""Pinch: the partner walks into a link no skin covers, through the real nodes (docs/phri_sim.md,
"Safe when following fails").

Two leads of the waltz hold (``phri_sim.studies.leads``), each faster than the robot follows:

* **into the unsensed wrist** — the partner walks forward along the left forearm at 0.5 m/s for
  0.40 m, past the forearm's end into the left wrist (2.5× the fastest lead along the forearm the
  robot follows), under a track force of 1000 N/m (:data:`PRESSING`). Without the controller's
  guard the robot, following the waist with its track force and desired force, keeps pressing
  the waist against the wrist: 73 N peak, **62 N held** (measured, bench/bench_pinch.py). With it
  the motion into the contact is slowed: 34 N peak, 33 N held (this run: slowed 98 periods,
  34 / 29 N). The default set's 300 N/m presses only 22 / 17 N there, without a reaction.
* **between two links** — the partner walks at 0.3 m/s towards the robot's right, between the
  arms into the right arm's wrist (the left forearm holding its back): the guard stops the
  robot and backs it off.

Each test asserts what the robot did about the contact no skin felt (the guard slowed or
stopped it, said so on its report) and that no body part of the partner went above its ISO/TS
15066 limit; the wrist test also that the contact was held at most 55 N (half the abdomen's
110 N), which fails without the guard (62 N).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterator
from typing import Any

import pytest
import rclpy
from rclpy.context import Context

from phri_common.testing import isolate_ros_environment
from phri_sim.evaluation.body_forces import limit_failures
from phri_sim.ros.run_options import RunOptions
from phri_sim.ros.runner import ScenarioRun
from phri_sim.studies.leads import Lead, LeadTiming, lead_scenario

LEADS = {
    "wrist": (Lead("translate", 0.5, 0.0), 0.40),
    "between_links": (Lead("translate", 0.3, 270.0), 0.40),
}
PRESSING = {"wrist": {"k_eta": 1000.0}}
"""Controller settings under which a lead presses the partner against the unsensed link. The
default waltz set's track force (k_η 300 N/m) follows the walk into the wrist at 22 N peak /
16.7 N held, which the guard need not answer; with the earlier set's 1000 N/m the track force
drives the waist on into the wrist, and the guard must."""


def _run(name: str) -> dict[str, Any]:
    lead, distance = LEADS[name]
    scenario = lead_scenario(lead, LeadTiming(distance=distance, angle=0.5 * math.pi)
                             .profile(lead))
    if name in PRESSING:
        scenario = dataclasses.replace(scenario, controller_parameters={
            **scenario.controller_parameters, **PRESSING[name]})
    isolate_ros_environment()
    context = Context()
    rclpy.init(context=context)
    run = ScenarioRun(scenario, RunOptions(), context=context)
    try:
        metrics = run.run()
        report = run.controller.torque_watch.report  # type: ignore[attr-defined]
        metrics["guard"] = {"stops": report.stops, "slowed": report.slowed,
                            "peak_ratio": report.peak_ratio}
        stop = run.bridge.sim.robot.protective_stop
        metrics["protective_stops"] = sum(stop.status(s).stops for s in stop.arms)
    finally:
        run.close()
        context.try_shutdown()
    return metrics


@pytest.fixture(scope="module")
def runs() -> Iterator[dict[str, dict[str, Any]]]:
    done: dict[str, dict[str, Any]] = {}
    yield done


def _metrics(runs: dict[str, dict[str, Any]], name: str) -> dict[str, Any]:
    if name not in runs:
        runs[name] = _run(name)
    return runs[name]


@pytest.mark.ros
@pytest.mark.parametrize("name", list(LEADS))
def test_the_robot_reacts_and_no_part_goes_above_its_limit(
        runs: dict[str, dict[str, Any]], name: str) -> None:
    m = _metrics(runs, name)
    guard = m["guard"]
    assert guard["stops"] + guard["slowed"] + m["protective_stops"] > 0, (
        f"nothing reacted to the unsensed contact: {guard}")
    assert not limit_failures(m["iso15066"]), limit_failures(m["iso15066"])


@pytest.mark.ros
def test_the_unsensed_wrist_contact_is_held_low(runs: dict[str, dict[str, Any]]) -> None:
    m = _metrics(runs, "wrist")
    wrist = m["iso15066"]["robot_links"]["left_wrist_1_link"]
    assert wrist["peak_force"] > 20.0, "the partner never reached the wrist: no test"
    assert wrist["sustained_force"] <= 55.0
