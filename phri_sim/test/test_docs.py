"""docs/phri_sim.md agrees with the code: the bridge's full parameter table."""

from __future__ import annotations

from pathlib import Path

from phri_common.testing import assert_parameter_table
from phri_sim.ros.bridge import PARAMS

DOC = Path(__file__).resolve().parents[2] / "docs" / "phri_sim.md"


def test_parameter_table_matches_the_code() -> None:
    """Every row (name, type, unit, default, range, description), in order, none extra."""
    assert_parameter_table(DOC, PARAMS)


def test_every_module_is_in_the_pieces_table() -> None:
    text = DOC.read_text(encoding="utf-8")
    package = Path(__file__).resolve().parents[1] / "phri_sim"
    modules = sorted(p.relative_to(package).as_posix() for p in package.rglob("*.py")
                     if p.name != "__init__.py")
    missing = [m for m in modules if f"| `{m}` |" not in text]
    assert len(modules) >= 12
    assert not missing, f"modules missing from docs/phri_sim.md's table: {missing}"
