"""phri_sim's layout: its subpackages form layers, and nothing imports upwards."""

from __future__ import annotations

from pathlib import Path

from phri_common.testing import layer_violations

PACKAGE = Path(__file__).resolve().parents[1] / "phri_sim"
LAYERS = ("world", "scenarios", "evaluation", "ros", "studies")
"""Lowest first (docs/phri_sim.md, Pieces): the simulated world, the scenarios played in it, the
metrics of a run, the simulator on ROS 2 (bridge, lock-step runner), studies over many runs."""


def test_no_module_imports_from_a_layer_above_or_from_phri_bringup() -> None:
    assert layer_violations(PACKAGE, LAYERS, above=("phri_bringup",)) == []


def test_every_module_lives_in_a_layer() -> None:
    loose = [p.name for p in PACKAGE.glob("*.py") if p.name != "__init__.py"]
    assert loose == []
