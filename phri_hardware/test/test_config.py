"""The real-robot parameter files are valid for the nodes they configure."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from phri_common import paper
from phri_common.params import ParamSpec
from phri_hardware import base_guard_node, ur_arm_bridge_node
from skin_driver import node as skin_driver_node

CONFIG = Path(__file__).resolve().parents[1] / "config"
SPECS: dict[str, list[ParamSpec]] = {
    "/left/ur_arm_bridge": ur_arm_bridge_node.PARAMS,
    "/right/ur_arm_bridge": ur_arm_bridge_node.PARAMS,
    "/base_guard": base_guard_node.PARAMS,
    "/skin_driver_left": skin_driver_node.PARAMS,
    "/skin_driver_right": skin_driver_node.PARAMS,
}


def sections() -> list[tuple[str, str, dict]]:
    out = []
    for path in sorted(CONFIG.glob("*.yaml")):
        for node, body in yaml.safe_load(path.read_text(encoding="utf-8")).items():
            out.append((path.name, node, body["ros__parameters"]))
    return out


@pytest.mark.parametrize(("file", "node", "params"), sections())
def test_every_value_passes_its_parameter_spec(file: str, node: str, params: dict) -> None:
    assert node in SPECS, f"{file}: unknown node {node}"
    by_name = {s.name: s for s in SPECS[node]}
    for name, value in params.items():
        assert name in by_name, f"{file}: {node} has no parameter {name!r}"
        spec = by_name[name]
        assert type(spec.default) is type(value), f"{file}: {node}.{name} has the wrong type"
        spec.check(value)


def test_arms_are_distinct_and_complete() -> None:
    arms = {node: p for _, node, p in sections() if node.endswith("/ur_arm_bridge")}
    assert set(arms) == {"/left/ur_arm_bridge", "/right/ur_arm_bridge"}
    assert arms["/left/ur_arm_bridge"]["joint_prefix"] == "left_"
    assert arms["/right/ur_arm_bridge"]["joint_prefix"] == "right_"
    assert arms["/left/ur_arm_bridge"]["robot_ip"] != arms["/right/ur_arm_bridge"]["robot_ip"]
    for p in arms.values():
        # the bridges must not accept faster commands than the controller's Table II bound
        assert p["velocity_cap"] >= 0.15 and p["rate_hz"] == 100.0


def test_skin_layouts_match_board_ids() -> None:
    for _, node, p in sections():
        if node.startswith("/skin_driver"):
            assert len(p["board_ids"]) == len(p["layout_files"]), node


def test_hand_written_files_carry_the_single_source_values() -> None:
    """These files are written by hand (comments, placeholders); the paper's values in them must
    still be the ones of phri_common.paper (Table II bound, control rate, filter window)."""
    for _, node, p in sections():
        if node == "/base_guard":
            for axis in ("max_linear_x", "max_linear_y", "max_angular_z"):
                assert p[axis] == paper.VELOCITY_LIMIT, axis
        elif node.endswith("/ur_arm_bridge"):
            assert p["rate_hz"] == paper.CONTROL_RATE_HZ, node
        elif node.startswith("/skin_driver"):
            assert p["filter_window"] == paper.FILTER_WINDOW, node
