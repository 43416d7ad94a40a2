"""docs/skin_driver.md agrees with the code: the node's full parameter table."""

from __future__ import annotations

from pathlib import Path

from phri_common.testing import assert_parameter_table
from skin_driver.node import PARAMS

DOC = Path(__file__).resolve().parents[2] / "docs" / "skin_driver.md"


def test_parameter_table_matches_the_code() -> None:
    """Every row (name, type, unit, default, range, description), in order, none extra."""
    assert_parameter_table(DOC, PARAMS)
