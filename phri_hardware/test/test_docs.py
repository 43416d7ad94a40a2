"""docs/hardware.md agrees with the code (each node's full parameter table, from ParamSpec)."""

from __future__ import annotations

from pathlib import Path

import pytest

from phri_common.params import ParamSpec
from phri_common.testing import assert_parameter_table
from phri_hardware import base_guard_node, ur_arm_bridge_node

DOCS = Path(__file__).resolve().parents[2] / "docs"


@pytest.mark.parametrize("specs", [ur_arm_bridge_node.PARAMS, base_guard_node.PARAMS],
                         ids=["ur_arm_bridge", "base_guard"])
def test_parameter_table_matches_the_code(specs: list[ParamSpec]) -> None:
    """Every row (name, type, unit, default, range, description), in order, none extra."""
    assert_parameter_table(DOCS / "hardware.md", specs)


def test_bringup_guide_names_every_watchdog_parameter() -> None:
    guide = (DOCS / "bringup_guide.md").read_text(encoding="utf-8")
    for name in ("watchdog_frequency", "command_timeout", "connect_timeout", "report_timeout",
                 "velocity_cap", "rearm_velocity", "silence_timeout", "joint_state_timeout",
                 "odom_timeout", "contact_timeout"):
        assert f"`{name}`" in guide, name
