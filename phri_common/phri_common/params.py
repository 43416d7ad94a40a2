"""Declarative parameter specifications (pure, no rclpy).

Each node describes its parameters once as :class:`ParamSpec` objects: name, default, unit, range
and description. The same list declares the ROS parameters with descriptors
(:mod:`phri_common.ros_params`), validates every value set at start-up or at run time, and renders
the parameter table of each node's page in ``docs/`` (:func:`markdown_table`); each package's
docs test compares the page's table, row by row and cell by cell, with the rendered one
(:func:`table_in` finds it).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, fields
from typing import Any

ParamValue = bool | int | float | str | list[bool] | list[int] | list[float] | list[str]


class ParameterValueError(ValueError):
    """A parameter value is outside what its specification allows."""


@dataclass(frozen=True)
class ParamSpec:
    """One node parameter.

    Attributes:
        name: ROS parameter name.
        default: default value; its Python type fixes the ROS type (``list[float]`` = double array).
        description: what it does.
        unit: physical unit (``"-"`` if none).
        low, high: inclusive bounds for numbers and for every element of numeric arrays
            (``None`` = unbounded). NaN is always refused for doubles; ±inf only where a bound
            allows it (``high=math.inf``).
        length: required array length (``None`` = any).
        min_length: minimum array length.
        read_only: refused after start-up (topic and patch wiring).
        loosens: a protected safety setting (:mod:`phri_common.protected`): which change
            loosens it at run time — ``up`` (a larger value), ``down`` (a smaller one),
            ``magnitude`` (a larger norm of the array), ``up_or_off`` (larger, or 0 = check
            off); '' = not protected.
    """

    name: str
    default: ParamValue
    description: str
    unit: str = "-"
    low: float | None = None
    high: float | None = None
    length: int | None = None
    min_length: int = 0
    read_only: bool = False
    loosens: str = ""

    @property
    def is_array(self) -> bool:
        return isinstance(self.default, list)

    def range_text(self) -> str:
        """Human-readable allowed range, as used in error messages and docs."""
        parts = []
        if self.low is not None or self.high is not None:
            lo = "-inf" if self.low is None else f"{self.low:g}"
            hi = "inf" if self.high is None else f"{self.high:g}"
            parts.append(f"[{lo}, {hi}]")
        if self.length is not None:
            parts.append(f"{self.length} elements")
        elif self.min_length:
            parts.append(f"≥ {self.min_length} elements")
        return ", ".join(parts) if parts else "any"

    def check(self, value: Any) -> ParamValue:
        """Return ``value`` (normalised) if allowed, else raise :class:`ParameterValueError`.

        The message names the parameter and its allowed range.
        """
        if self.is_array:
            if not isinstance(value, (list, tuple)) and not hasattr(value, "tolist"):
                raise self._error(value, "expected an array")
            items = list(value.tolist() if hasattr(value, "tolist") else value)
            if self.length is not None and len(items) != self.length:
                raise self._error(value, f"expected {self.length} elements, got {len(items)}")
            if len(items) < self.min_length:
                raise self._error(value, f"expected at least {self.min_length} elements")
            return [self._check_scalar(item, value, i) for i, item in enumerate(items)]
        return self._check_scalar(value, value)

    @property
    def kind(self) -> type:
        """The Python type of the value (of each element for arrays): bool, int, float or str."""
        sample = self.default
        if isinstance(sample, list):
            sample = sample[0] if sample else ""
        return type(sample)

    def _check_type(self, item: Any, whole: Any, index: int | None = None) -> Any:
        kind = self.kind
        ok = isinstance(item, kind) and (kind is bool or not isinstance(item, bool))
        if kind is float and isinstance(item, int) and not isinstance(item, bool):
            return float(item)  # an integer is a fine double
        if not ok:
            what = "an array of " if self.is_array else ""
            raise self._error(whole, f"expected {what}{kind.__name__}, got "
                                     f"{type(item).__name__}", index)
        return item

    def _check_scalar(self, item: Any, whole: Any, index: int | None = None) -> Any:
        item = self._check_type(item, whole, index)
        if isinstance(item, (bool, str)):
            return item
        if isinstance(item, (int, float)):
            x = float(item)
            why = None
            if math.isnan(x):
                why = "NaN is not allowed"
            elif self.low is not None and x < self.low:
                why = "below the allowed range"
            elif self.high is not None and x > self.high:
                why = "above the allowed range"
            elif math.isinf(x) and (self.high is None or not math.isinf(self.high)) and x > 0:
                why = "infinity is not allowed"
            elif math.isinf(x) and x < 0 and (self.low is None or not math.isinf(self.low)):
                why = "-infinity is not allowed"
            if why is not None:
                raise self._error(whole if index is None else item, why, index)
            return item
        raise self._error(whole, f"unsupported type {type(item).__name__}", index)

    def _error(self, value: Any, why: str, index: int | None = None) -> ParameterValueError:
        unit = "" if self.unit == "-" else f" [{self.unit}]"
        name = self.name if index is None else f"{self.name}[{index}]"
        return ParameterValueError(
            f"parameter '{name}'{unit} refused value {value!r}: {why}; "
            f"allowed range: {self.range_text()}"
        )


TABLE_HEADER = (
    "| parameter | type | unit | default | range | description |",
    "|---|---|---|---|---|---|",
)
"""The first two lines of every parameter table."""


def _cell(text: str) -> str:
    """Markdown table cell text: a literal ``|`` (as in ``|q̇|``) escaped so it does not split
    the cell."""
    return text.replace("|", "\\|")


def markdown_table(specs: Sequence[ParamSpec]) -> str:
    """Render specs as a Markdown table (name, type, unit, default, range, description)."""
    rows = list(TABLE_HEADER)
    for spec in specs:
        kind = type(spec.default).__name__
        if spec.is_array:
            assert isinstance(spec.default, list)
            elem = type(spec.default[0]).__name__ if spec.default else "str"
            kind = f"{elem}[]"
        ro = " (read-only)" if spec.read_only else (
            " (protected: loosening needs the unlock)" if spec.loosens else "")
        rows.append(
            f"| `{spec.name}` | {kind} | {_cell(spec.unit)} | `{spec.default!r}` "
            f"| {spec.range_text()} | {_cell(spec.description)}{ro} |"
        )
    return "\n".join(rows)


def table_in(markdown: str, first_parameter: str) -> str:
    """The parameter table of a Markdown page whose first row documents ``first_parameter``:
    its header, rule and every row up to the first line that is not a table row, joined as
    :func:`markdown_table` joins them; ``""`` when the page has no such table."""
    lines = markdown.splitlines()
    first = f"| `{first_parameter}` |"
    for i in range(len(lines) - 2):
        if tuple(lines[i:i + 2]) == TABLE_HEADER and lines[i + 2].startswith(first):
            end = i + 2
            while end < len(lines) and lines[end].startswith("|"):
                end += 1
            return "\n".join(lines[i:end])
    return ""


def setting(name: str, default: Any, description: str, unit: str = "-",
            low: float | None = None, high: float | None = None, **options: Any) -> Any:
    """A dataclass field that is also a parameter: its default, and the :class:`ParamSpec`
    (ROS name ``name``, unit, range, description) in its metadata under ``"param"``.

    The configuration dataclass is then the one record of the parameter: the node declares
    :func:`settings_of` it, the docs table renders it, :func:`check_settings` validates it and
    the code that reads the field is the one that uses it. ``options`` go to :class:`ParamSpec`
    (``length``, ``read_only``, …); a tuple default is declared as a ROS array.
    """
    ros_default = list(default) if isinstance(default, tuple) else default
    spec = ParamSpec(name, ros_default, description, unit, low, high, **options)
    return field(default=default, metadata={"param": spec})


def settings_of(cls: type) -> list[ParamSpec]:
    """The :class:`ParamSpec` of every :func:`setting` field of a dataclass, in field order."""
    return [f.metadata["param"] for f in fields(cls) if "param" in f.metadata]


def check_settings(obj: Any) -> None:
    """Validate every :func:`setting` field of a dataclass instance against its spec.

    Raises:
        ParameterValueError: a value outside its range (the message names the parameter).
    """
    for f in fields(obj):
        spec = f.metadata.get("param")
        if spec is not None:
            value = getattr(obj, f.name)
            spec.check(list(value) if isinstance(value, tuple) else value)


def values_for(cls: type, values: Mapping[str, Any]) -> dict[str, Any]:
    """Keyword arguments for ``cls`` from parameter ``values`` keyed by ROS name: every
    :func:`setting` field whose parameter is in ``values`` (arrays as tuples)."""
    out = {}
    for f in fields(cls):
        spec = f.metadata.get("param")
        if spec is not None and spec.name in values:
            value = values[spec.name]
            out[f.name] = tuple(value) if isinstance(value, list) else value
    return out
