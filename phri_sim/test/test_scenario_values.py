"""Scenarios and run options as values: a run takes a Scenario and frozen RunOptions, variants are
made with dataclasses.replace, and nothing is registered in (or patched into) SCENARIOS."""

from __future__ import annotations

import dataclasses
from typing import Any

import pytest
from rclpy.parameter import Parameter

from phri_sim.ros.bridge import SimBridgeNode
from phri_sim.ros.run_options import RunOptions
from phri_sim.ros.runner import ScenarioRun
from phri_sim.scenarios.catalogue import (
    PARAMETER_SETS,
    SCENARIOS,
    scenario_named,
    with_parameter_set,
)


def test_run_options_are_frozen_and_refuse_unknown_choices() -> None:
    options = RunOptions(duration=2.0)
    with pytest.raises(dataclasses.FrozenInstanceError):
        options.seed = 3  # type: ignore[misc]
    assert dataclasses.replace(options, seed=3).seed == 3 and options.seed == 0
    for field, value in (("fidelity", "slow"), ("controller", "mock"),
                         ("sensor_transport", "pigeon")):
        with pytest.raises(ValueError, match=field):
            RunOptions(**{field: value})


def test_length_is_the_duration_or_the_scenarios() -> None:
    waltz = SCENARIOS["waltz"]
    assert RunOptions().length(waltz) == waltz.duration
    assert RunOptions(short=True).length(waltz) == waltz.short_duration
    assert RunOptions(duration=1.5, short=True).length(waltz) == 1.5


def test_a_parameter_set_is_a_new_value_and_the_catalogue_is_unchanged() -> None:
    before = dict(SCENARIOS["centring"].controller_parameters)
    literal = with_parameter_set(scenario_named("centring"), "literal")
    assert literal.controller_parameters == PARAMETER_SETS["centring"]["literal"]
    assert literal.controller_parameters != before
    assert SCENARIOS["centring"].controller_parameters == before
    with pytest.raises(ValueError, match="parameter set 'bogus'"):
        with_parameter_set(literal, "bogus")
    with pytest.raises(ValueError, match="unknown scenario 'tango'"):
        scenario_named("tango")


@pytest.mark.ros
def test_the_bridge_plays_a_scenario_given_as_a_value(ros_context: Any) -> None:
    """A scenario the catalogue does not hold runs when given in-process; the ``scenario``
    parameter (for launch files) must then be '' or its name."""
    variant = dataclasses.replace(SCENARIOS["waltz"], name="waltz_variant")
    node = SimBridgeNode(scenario=variant, context=ros_context, parameter_overrides=[
        Parameter("lockstep", value=True), Parameter("scenario", value="waltz_variant")])
    try:
        assert node.scenario is variant and node.script is not None
    finally:
        node.destroy_node()
    with pytest.raises(ValueError, match="parameter 'scenario' refused value 'waltz'"):
        SimBridgeNode(scenario=variant, context=ros_context, parameter_overrides=[
            Parameter("lockstep", value=True), Parameter("scenario", value="waltz")])
    assert "waltz_variant" not in SCENARIOS


@pytest.mark.ros
def test_a_run_of_an_unregistered_variant_gives_its_nodes_its_values(ros_context: Any) -> None:
    """A variant made with dataclasses.replace (another name, another k_eta) runs as it is: the
    controller holds its parameters, the metrics carry its name, the catalogue never hears of
    it."""
    base = SCENARIOS["centring"]
    variant = dataclasses.replace(base, name="centring_k_eta_300", controller_parameters={
        **base.controller_parameters, "k_eta": 300.0})
    run = ScenarioRun(variant, RunOptions(duration=0.05), context=ros_context)
    try:
        assert run.controller.get_parameter("k_eta").value == 300.0
        assert run.bridge.scenario is variant
        assert "centring_k_eta_300" not in SCENARIOS
        metrics = run.run()
    finally:
        run.close()
    assert metrics["scenario"] == "centring_k_eta_300"
    assert base.controller_parameters["k_eta"] != 300.0
