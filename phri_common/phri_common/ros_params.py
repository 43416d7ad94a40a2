"""Declare and validate ROS parameters from :class:`~phri_common.params.ParamSpec` lists.

Node-side helper (imports rclpy). A bad value given at start-up raises
:class:`~phri_common.params.ParameterValueError` (the node refuses to start with a message naming
the parameter and its range); a bad value set at run time is refused through the set-parameters
callback with the same message, and the node keeps its previous value.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

from rcl_interfaces.msg import ParameterDescriptor, SetParametersResult
from rclpy.exceptions import InvalidParameterTypeException, InvalidParameterValueException
from rclpy.node import Node
from rclpy.parameter import Parameter

from phri_common.params import ParameterValueError, ParamSpec, ParamValue
from phri_common.protected import UNLOCK_PARAM, loosening_changes, refusal


def _descriptor(spec: ParamSpec) -> ParameterDescriptor:
    """The ROS descriptor: description, unit, type and range as text, read-only flag.

    Type and range are checked by :meth:`ParamSpec.check` in our set-parameters callback, not by
    rclpy's descriptor checks (``dynamic_typing``, no ``*_range``): rclpy would refuse first with
    "Wrong parameter type, expected '3' got '4'" or its own range text, naming neither the
    parameter nor the value; ours names the parameter, the value, the type and the range.
    """
    unit = "" if spec.unit == "-" else f" [{spec.unit}]"
    kind = f"{'array of ' if spec.is_array else ''}{spec.kind.__name__}"
    return ParameterDescriptor(
        description=f"{spec.description}{unit}",
        additional_constraints=f"type: {kind}; allowed range: {spec.range_text()}",
        read_only=spec.read_only,
        dynamic_typing=True,
    )


def _ros_type(spec: ParamSpec) -> Parameter.Type:
    d = spec.default
    if isinstance(d, list):
        sample = d[0] if d else ""
        return {
            bool: Parameter.Type.BOOL_ARRAY,
            int: Parameter.Type.INTEGER_ARRAY,
            float: Parameter.Type.DOUBLE_ARRAY,
            str: Parameter.Type.STRING_ARRAY,
        }[type(sample)]
    return {
        bool: Parameter.Type.BOOL,
        int: Parameter.Type.INTEGER,
        float: Parameter.Type.DOUBLE,
        str: Parameter.Type.STRING,
    }[type(d)]


def declare_parameters(
    node: Node,
    specs: Sequence[ParamSpec],
    on_change: Callable[[dict[str, ParamValue]], None] | None = None,
) -> dict[str, ParamValue]:
    """Declare every spec on ``node`` and return the validated start-up values by name.

    Args:
        node: the node.
        specs: its parameters.
        on_change: called with the new values (all parameters) after a run-time change passed
            validation; if it raises ``ValueError`` the change is refused with that message.

    Raises:
        ParameterValueError: a start-up value (override from YAML or command line) is refused.
    """
    by_name = {s.name: s for s in specs}
    values: dict[str, ParamValue] = {}
    for spec in specs:
        try:
            if spec.is_array and not spec.default:
                descriptor = _descriptor(spec)
                descriptor.dynamic_typing = False  # rclpy: a given type excludes dynamic typing
                param: Parameter = node.declare_parameter(spec.name, _ros_type(spec), descriptor)
                raw = param.value if param.value is not None else []
            else:
                raw = node.declare_parameter(spec.name, spec.default, _descriptor(spec)).value
        except (InvalidParameterValueException, InvalidParameterTypeException) as err:
            # rclpy's own range/type check fired first: re-raise with our message.
            override = node._parameter_overrides.get(spec.name)
            value = override.value if override is not None else None
            spec.check(value)  # raises ParameterValueError naming the range if out of range
            raise ParameterValueError(f"parameter '{spec.name}' refused: {err}") from err
        values[spec.name] = spec.check(raw)

    protected = any(spec.loosens for spec in specs)
    if protected and UNLOCK_PARAM.name not in by_name and not node.has_parameter(
            UNLOCK_PARAM.name):
        raise ValueError(f"protected settings need the '{UNLOCK_PARAM.name}' parameter")
    node.add_on_set_parameters_callback(_validator(node, values, by_name, on_change, protected))
    return values


def _validator(node: Node, values: dict[str, ParamValue], by_name: dict[str, ParamSpec],
               on_change: Callable[[dict[str, ParamValue]], None] | None, protected: bool
               ) -> Callable[[list[Parameter]], SetParametersResult]:
    """The set-parameters callback: each value checked against its spec, a loosening of a
    protected setting refused unless unlocked (:mod:`phri_common.protected`), ``on_change``
    called; accepted loosenings and a change of the unlock logged at WARN."""

    def _validate(params: list[Parameter]) -> SetParametersResult:
        proposed = dict(values)
        try:
            changed = {}
            for p in params:
                spec = by_name.get(p.name)
                if spec is None:
                    continue
                proposed[p.name] = changed[p.name] = spec.check(p.value)
            loosening = loosening_changes(by_name, values, changed) if protected else []
            if loosening and not _unlocked(node, proposed):
                raise ValueError(refusal(loosening))
            if on_change is not None:
                on_change(proposed)
        except (ParameterValueError, ValueError) as err:
            node.get_logger().warning(str(err))
            return SetParametersResult(successful=False, reason=str(err))
        for line in loosening:
            node.get_logger().warning(f"protected safety setting loosened (unlocked): {line}")
        unlock = changed.get(UNLOCK_PARAM.name)
        if unlock is not None and unlock != values.get(UNLOCK_PARAM.name):
            state = "UNLOCKED" if unlock else "locked again"
            node.get_logger().warning(f"protected safety settings {state} "
                                      f"({UNLOCK_PARAM.name} = {unlock})")
        values.update(proposed)
        return SetParametersResult(successful=True)

    return _validate


def _unlocked(node: Node, proposed: dict[str, ParamValue]) -> bool:
    """Whether the unlock is on in ``proposed`` (declared in this list) or on the node."""
    if UNLOCK_PARAM.name in proposed:
        return bool(proposed[UNLOCK_PARAM.name])
    return bool(node.has_parameter(UNLOCK_PARAM.name)
                and node.get_parameter(UNLOCK_PARAM.name).value)


def param_value(values: dict[str, ParamValue], name: str) -> Any:
    """Typed-loosely accessor (keeps call sites short)."""
    return values[name]
