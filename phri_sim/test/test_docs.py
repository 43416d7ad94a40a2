"""docs/phri_sim.md documents every bridge parameter."""

from __future__ import annotations

from pathlib import Path

from phri_sim.bridge import PARAMS

DOC = Path(__file__).resolve().parents[2] / "docs" / "phri_sim.md"


def test_every_parameter_is_documented() -> None:
    text = DOC.read_text(encoding="utf-8")
    missing = [spec.name for spec in PARAMS if f"`{spec.name}`" not in text]
    assert not missing, f"undocumented parameters: {missing}"
