"""Protected safety settings: a run-time change that loosens one needs an explicit, logged
unlock (pure, no rclpy).

Some parameters hold a person's safety: force limits, the yield, input timeouts, the largest
plausible contact force, the desired force, the skin's plausibility checks. A
:class:`~phri_common.params.ParamSpec` with ``loosens`` set is *protected*: at start-up (launch
file, YAML, command line) it takes any value in its range, as every parameter does; at run time
(``ros2 param set``, the parameter services) a change in its ``loosens`` direction — a higher
force limit or timeout, a lower yield speed, a larger desired force, a check switched off — is
refused unless the node's :data:`UNLOCK_PARAM` (``safety_settings_unlocked``) is true in the same
or an earlier request. Tightening is always accepted. Every accepted loosening, and every change
of the unlock itself, is logged at WARN with the old and the new value, so the change can be
traced (:mod:`phri_common.ros_params` applies the policy).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

from phri_common.params import ParamSpec

LOOSENS = ("up", "down", "magnitude", "up_or_off")
"""The values of ``ParamSpec.loosens`` (besides '' = not protected)."""

UNLOCK_PARAM = ParamSpec(
    "safety_settings_unlocked", False, "allow run-time changes that loosen a protected safety "
    "setting (force limits, yield, timeouts, max contact force, desired force, skin "
    "plausibility); each is logged at WARN, and so is this switch; false locks them again")
"""The unlock (module docstring); declared by every node with protected settings."""


def _norm(value: Any) -> float:
    items = value if isinstance(value, list) else [value]
    return math.sqrt(sum(float(x) * float(x) for x in items))


def loosened(spec: ParamSpec, old: Any, new: Any) -> bool:
    """Whether changing ``spec`` from ``old`` to ``new`` loosens it (``spec.loosens``); arrays
    of ``up`` / ``down`` settings loosen when any element does."""
    kind = spec.loosens
    if not kind or old == new:
        return False
    if kind == "magnitude":
        return _norm(new) > _norm(old)
    olds = old if isinstance(old, list) else [old]
    news = new if isinstance(new, list) else [new]
    for a, b in zip(olds, news, strict=False):
        a, b = float(a), float(b)
        if kind == "up" and b > a:
            return True
        if kind == "down" and b < a:
            return True
        if kind == "up_or_off" and a != 0.0 and (b > a or b == 0.0):
            return True
    return False


def loosening_changes(specs: Mapping[str, ParamSpec], current: Mapping[str, Any],
                      proposed: Mapping[str, Any]) -> list[str]:
    """``'name: old → new'`` for every protected setting ``proposed`` loosens."""
    out = []
    for name, new in proposed.items():
        spec = specs.get(name)
        if spec is not None and name in current and loosened(spec, current[name], new):
            out.append(f"{name}: {current[name]!r} → {new!r}")
    return out


def refusal(changes: list[str]) -> str:
    """The refusal message of loosening ``changes`` without the unlock."""
    return (f"refused: loosening protected safety setting(s) at run time ({'; '.join(changes)})"
            f" needs '{UNLOCK_PARAM.name}' set to true first (an explicit, logged unlock; "
            "docs/wholebody_controller.md, Protected settings)")
