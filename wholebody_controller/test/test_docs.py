"""The interface doc names every parameter, topic and service of the node."""

from __future__ import annotations

from pathlib import Path

from wholebody_controller.parameters import PARAMS

DOC = Path(__file__).resolve().parents[2] / "docs" / "wholebody_controller.md"


def test_every_parameter_is_documented() -> None:
    text = DOC.read_text(encoding="utf-8")
    missing = [spec.name for spec in PARAMS if f"`{spec.name}`" not in text]
    assert not missing, f"undocumented parameters: {missing}"


def test_topics_and_services_are_documented() -> None:
    text = DOC.read_text(encoding="utf-8")
    for name in ("contacts/<link>", "/joint_states", "/odom", "/cmd_vel",
                 "left/forward_velocity_controller/commands",
                 "right/forward_velocity_controller/commands", "~/state/<link>",
                 "~/record_q_dance", "~/release_q_dance", "~/reset"):
        assert f"`{name}`" in text, name
