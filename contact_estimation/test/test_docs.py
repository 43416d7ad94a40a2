"""docs/contact_estimation.md agrees with the code: the full parameter table."""

from __future__ import annotations

from pathlib import Path

from contact_estimation.node import PARAMS
from phri_common.testing import assert_parameter_table

DOC = Path(__file__).resolve().parents[2] / "docs" / "contact_estimation.md"


def test_parameter_table_matches_the_code() -> None:
    """Every row (name, type, unit, default, range, description), in order, none extra."""
    assert_parameter_table(DOC, PARAMS)
