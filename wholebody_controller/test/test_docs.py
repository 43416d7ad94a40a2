"""The interface doc agrees with the node: the full parameter table, every topic and service."""

from __future__ import annotations

from pathlib import Path

from phri_common.testing import assert_parameter_table
from wholebody_controller.parameters import PARAMS

DOC = Path(__file__).resolve().parents[2] / "docs" / "wholebody_controller.md"


def test_parameter_table_matches_the_code() -> None:
    """Every row (name, type, unit, default, range, description), in order, none extra."""
    assert_parameter_table(DOC, PARAMS)


def test_topics_and_services_are_documented() -> None:
    text = DOC.read_text(encoding="utf-8")
    for name in ("contacts/<link>", "/joint_states", "/odom", "/cmd_vel",
                 "left/forward_velocity_controller/commands",
                 "right/forward_velocity_controller/commands", "~/state/<link>",
                 "~/record_q_dance", "~/release_q_dance", "~/reset"):
        assert f"`{name}`" in text, name
