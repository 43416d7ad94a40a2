"""Parameter specifications refuse bad values with a message naming parameter and range."""

from __future__ import annotations

import math

import pytest

from phri_common.params import ParameterValueError, ParamSpec, markdown_table, table_in


def test_in_range_value_is_accepted() -> None:
    spec = ParamSpec("force_threshold", 0.05, "σ_t", unit="N", low=0.0, high=100.0)
    assert spec.check(1.5) == 1.5


@pytest.mark.parametrize("bad", [-0.1, 100.5, math.nan, math.inf])
def test_out_of_range_scalar_names_parameter_and_range(bad: float) -> None:
    spec = ParamSpec("force_threshold", 0.05, "σ_t", unit="N", low=0.0, high=100.0)
    with pytest.raises(ParameterValueError, match=r"force_threshold.*\[0, 100\]"):
        spec.check(bad)


def test_infinity_allowed_only_when_the_bound_is_infinite() -> None:
    spec = ParamSpec("torque_limit", [math.inf, math.inf, 1.2], "τ", unit="N·m", low=0.0,
                     high=math.inf, length=3)
    assert spec.check([math.inf, 1.0, 1.2]) == [math.inf, 1.0, 1.2]
    with pytest.raises(ParameterValueError, match="3 elements"):
        spec.check([1.0, 1.0])
    with pytest.raises(ParameterValueError, match="torque_limit"):
        spec.check([1.0, -1.0, 1.0])


def test_markdown_table_lists_every_parameter() -> None:
    specs = [ParamSpec("a", 1.0, "first", unit="m", low=0.0), ParamSpec("b", ["x"], "second")]
    table = markdown_table(specs)
    assert "`a`" in table and "`b`" in table and "| m |" in table


def test_markdown_table_escapes_pipes_inside_cells() -> None:
    table = markdown_table([ParamSpec("v", 0.15, "bound on |q̇|", unit="rad/s")])
    row = table.splitlines()[2]
    assert "\\|q̇\\|" in row
    # Six cells: the unescaped separators alone split the row.
    assert len(row.replace("\\|", "").strip("|").split("|")) == 6


def test_table_in_returns_the_whole_table_and_nothing_else() -> None:
    specs = [ParamSpec("a", 1.0, "first", unit="m", low=0.0), ParamSpec("b", 2, "second")]
    table = markdown_table(specs)
    other = "| other | table |\n|---|---|\n| x | y |"
    page = f"# Page\n\n{other}\n\n{table}\n| `c` | stale |\n\nText\n"
    found = table_in(page, "a")
    assert found.splitlines()[:4] == table.splitlines()
    assert found.splitlines()[4] == "| `c` | stale |"  # a left-over row is part of the table
    assert table_in(page, "b") == ""  # b is not the first row of any table
    assert table_in("no tables here", "a") == ""
