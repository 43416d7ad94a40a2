"""docs/phri_sim.md agrees with the code: the bridge's full parameter table."""

from __future__ import annotations

from pathlib import Path

from phri_common.testing import assert_parameter_table
from phri_sim.bridge import PARAMS

DOC = Path(__file__).resolve().parents[2] / "docs" / "phri_sim.md"


def test_parameter_table_matches_the_code() -> None:
    """Every row (name, type, unit, default, range, description), in order, none extra."""
    assert_parameter_table(DOC, PARAMS)
