"""The interface documentation agrees with the code."""

from __future__ import annotations

from pathlib import Path

from contact_estimation.node import PARAMS
from phri_common.params import markdown_table

DOC = Path(__file__).resolve().parents[2] / "docs" / "contact_estimation.md"


def test_every_parameter_row_in_the_docs_matches_the_code() -> None:
    text = DOC.read_text(encoding="utf-8")
    for row in markdown_table(PARAMS).splitlines()[2:]:
        assert row in text, f"docs/contact_estimation.md is out of date; expected row:\n{row}"
