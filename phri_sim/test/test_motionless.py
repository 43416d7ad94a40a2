"""The motionless baseline on the world alone (phri_sim.ros.motionless) is the lock-step run with
the zero-command stub, value for value: the person, the shove, the plant and the metrics are the
same code, and a robot that is never commanded does what one commanded zero does."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest

from phri_common.params import ParameterValueError
from phri_sim.ros.motionless import MOTIONLESS, bridge_values, run_motionless
from phri_sim.ros.run_options import RunOptions
from phri_sim.ros.runner import run_scenario
from phri_sim.scenarios.catalogue import scenario_named

TIMING_AND_NAMES = {"wall_time", "real_time_factor", "cpu_time", "real_time_factor_cpu",
                    "controller", "commands_refused"}


def differences(a: Any, b: Any, path: str = "") -> list[str]:
    """Where two metrics trees differ (NaN equals NaN)."""
    if isinstance(a, dict) and isinstance(b, dict):
        keys = (set(a) | set(b)) - (TIMING_AND_NAMES if not path else set())
        return [d for k in sorted(keys) for d in (
            [f"{path}/{k}: missing"] if k not in a or k not in b
            else differences(a[k], b[k], f"{path}/{k}"))]
    if isinstance(a, list) and isinstance(b, list) and len(a) == len(b):
        return [d for i, (x, y) in enumerate(zip(a, b, strict=True))
                for d in differences(x, y, f"{path}[{i}]")]
    same = a == b or (isinstance(a, float) and isinstance(b, float)
                      and math.isnan(a) and math.isnan(b))
    return [] if same else [f"{path}: {a!r} != {b!r}"]


@pytest.mark.ros
@pytest.mark.parametrize("plant, shove", [("realistic", ""), ("ideal", "120N@5s+1s")])
def test_the_world_alone_gives_the_stubs_metrics(ros_context: Any, plant: str,
                                                 shove: str) -> None:
    waltz = scenario_named("waltz")
    options = RunOptions(duration=8.0, plant=plant, shove=shove)
    still, series = run_motionless(waltz, options)
    stub = run_scenario(waltz, RunOptions(duration=8.0, plant=plant, shove=shove,
                                          controller="stub"), context=ros_context)
    assert differences(stub, still) == []
    assert still["controller"] == MOTIONLESS
    assert series is not None and len(series.times) == 800
    # What the comparison stands on: the partner presses the robot and moves it nowhere.
    assert max(still["following"]["peak_force"]["person"].values()) > 5.0
    assert np.ptp(series.base, axis=0).max() < 0.01
    if shove:
        assert still["shove"]["peak_applied"] == pytest.approx(120.0)


def test_a_shorter_motionless_run_differs(ros_context: Any) -> None:
    """The comparison can fail: two lengths give other metrics."""
    waltz = scenario_named("waltz")
    short, _ = run_motionless(waltz, RunOptions(duration=3.0))
    longer, _ = run_motionless(waltz, RunOptions(duration=3.5))
    assert differences(short, longer) != []


def test_bridge_values_are_checked_as_the_node_checks_them() -> None:
    values = bridge_values(scenario_named("waltz"), RunOptions(seed=7))
    assert values["seed"] == 7 and values["control_period"] == pytest.approx(0.01)
    with pytest.raises(ParameterValueError, match="seed"):
        bridge_values(scenario_named("waltz"), RunOptions(seed=-1))
