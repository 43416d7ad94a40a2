"""Safe when following fails (the guard): the partner's shove and the skin faults that look like
readings, on the short waltz through the real nodes.

* The shove: the partner pushes the waist into the left forearm with 250 N for 3 s from 12, 20
  or 30 s (the ``push`` kind, :mod:`phri_sim.world.shove`). Before the graded yield (the arm
  yielding at 0.15 m/s, held in the q_dance band and Table II's 0.15) the waist took 1671 N
  peak / 139 N held and the torso struck the right upper arm. With it the waist stays within its
  limits (220 N transient, 110 N held 0.5 s) at every time; what the rest of the torso meets is
  an open finding (:func:`test_the_shoved_partner_stays_within_every_limit`).
* A frozen-but-noisy left-forearm patch, a half-dead one: before, the robot drove on on the lie
  (1.15 m and 0.75 m in 15 s, 83 / 80 N and 85 / 81 N on the waist, never stopping). With the
  skin's plausibility checks the patch is refused (diagnostics ERROR), the contact input goes
  stale and the command is an exact zero to the end (the lock-step runner's contact timeout is
  2 s), the partner's forces within limits. The frozen-noisy patch is also stopped by the
  controller's skin-frozen check alone (the dead-region check, which finds the frozen patch
  first by its noiseless zeros, off; the gain check out of the way): contact estimation only
  reports a still patch, since a partner holding still reads the same.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import pytest

from phri_sim.evaluation.body_forces import limit_failures
from phri_sim.ros.run_options import RunOptions
from phri_sim.ros.runner import run_scenario
from phri_sim.scenarios.catalogue import SCENARIOS

FAULT_TIME = 5.0
AFTER = 5.0
"""Seconds run after the fault / the shove's start."""


def _within_limits(block: dict[str, Any]) -> None:
    bad = {k: v for k, v in block["forces"]["person"].items() if not v["ok"]}
    assert not bad, f"person pushed past ISO/TS 15066: {bad}"
    assert not limit_failures(block["forces"])


SHOVE_TIMES = (12.0, 20.0, 30.0)
"""When the shove starts [s]: in the closed change (12 s), as the first natural turn begins
(20 s), inside it (30 s). What the shoved partner meets depends on the posture the shove finds:
with the earlier default set (Λ_rz 0.01, k_η 1000) the waist took 241 N at 12 s (over its
220 N), and 172 / 107 N at 20 s."""


@pytest.fixture(scope="module")
def shoves() -> dict[float, dict[str, Any]]:
    return {}


def _shove(shoves: dict[float, dict[str, Any]], start: float) -> dict[str, Any]:
    if start not in shoves:
        shoves[start] = run_scenario("waltz", RunOptions(
            duration=start + 5.0, seed=0, plant="realistic", shove=f"250N@{start:g}s+3s"))
    return shoves[start]


@pytest.mark.ros
@pytest.mark.parametrize("start", SHOVE_TIMES)
def test_a_250_N_shove_for_3_s_is_yielded_to_at_the_waist(
        shoves: dict[float, dict[str, Any]], start: float) -> None:
    """On the realistic plant (the drives a real robot has), the waist the shove drives into the
    yielding forearm within its limits: 197 / 93 N (12 s), 197 / 84 N (20 s), 203 / 103 N
    (30 s)."""
    m = _shove(shoves, start)
    assert m["shove"]["peak_applied"] == 250.0
    waist = m["fault"]["forces"]["person"]["person_waist"]
    assert waist["peak_force"] > 110.0  # the shove reached the limit: the yield was exercised
    assert waist["peak_force"] <= 220.0, waist
    assert waist["sustained_force"] <= 110.0, waist


@pytest.mark.ros
def test_the_shoved_partner_stays_within_every_limit(
        shoves: dict[float, dict[str, Any]]) -> None:
    """Every body part within its limits for every shove time. Without the torque input's
    gate (T1, ``turn_force_limit`` 20 N in the waltz set) it failed at 20 s: after the yield the
    decaying push, off-centre on the forearm, turned the base at its limit and swept the
    unskinned right wrist into the rebounding abdomen (412 N peak, 48 N held)."""
    for start in SHOVE_TIMES:
        _within_limits(_shove(shoves, start)["fault"])


def _stops_on(fault: str, after: float = AFTER, controller: dict[str, Any] | None = None,
              **estimation: float) -> dict[str, Any]:
    scenario = SCENARIOS["waltz"]
    if estimation:
        scenario = dataclasses.replace(scenario, estimation_parameters={
            **scenario.estimation_parameters, **estimation})
    if controller:
        scenario = dataclasses.replace(scenario, controller_parameters={
            **scenario.controller_parameters, **controller})
    m = run_scenario(scenario, RunOptions(duration=FAULT_TIME + after, seed=1, fault=fault,
                                          fault_patch="left_forearm", fault_time=FAULT_TIME))
    f = m["fault"]
    _within_limits(f)
    # Stopped with an exact zero (every one of the 15 values) that lasts to the end.
    assert f["time_to_stop"] is not None, f
    return f


@pytest.mark.ros
def test_a_half_dead_patch_stops_the_robot_with_an_exact_zero() -> None:
    f = _stops_on("skin_half_dead")
    assert f["time_to_stop"] <= 3.5 and f["base_travel"] <= 0.3


@pytest.mark.ros
def test_a_frozen_noisy_patch_stops_the_robot_with_an_exact_zero() -> None:
    f = _stops_on("skin_frozen_noisy")
    assert f["time_to_stop"] <= 3.5 and f["base_travel"] <= 0.3


@pytest.mark.ros
def test_the_joints_alone_stop_a_frozen_noisy_patch_that_is_merely_still() -> None:
    """The dead-region check off (it finds the patch first by its noiseless zeros) and the gain
    check out of the way (ratio 100): the still patch is not refused by contact estimation (a
    still hold is no lie), and the controller's skin_frozen verdict — the skin still while the
    joints feel its contact change — stops the robot (measured 1.87 s; the gain check alone
    2.15 s; the skin-alone refusal of a still patch it replaces: 2.15 s)."""
    f = _stops_on("skin_frozen_noisy", after=8.0, controller={"skin_max_gain_ratio": 100.0},
                  plausibility_dead_time=0.0)
    assert f["time_to_stop"] <= 2.5
