"""phri_bringup's layout: its subpackages form layers, nothing imports upwards, and
docs/bringup.md lists every module."""

from __future__ import annotations

from pathlib import Path

from phri_common.testing import layer_violations

PACKAGE = Path(__file__).resolve().parents[1] / "phri_bringup"
DOC = Path(__file__).resolve().parents[2] / "docs" / "bringup.md"
LAYERS = ("graph", "observer", "reports", "cli")
"""Lowest first (docs/bringup.md, Code layout): the node graph and its parameter files, watching
a run (observer node, recordings, live view), offline reports, the command and its session. The
top-level modules (``compile_kernels``, ``skin_contact_node``) are entry points above them all."""


def test_no_module_imports_from_a_layer_above() -> None:
    assert layer_violations(PACKAGE, LAYERS) == []


def test_every_module_is_in_the_code_layout_table() -> None:
    text = DOC.read_text(encoding="utf-8")
    modules = sorted(p.relative_to(PACKAGE).as_posix() for p in PACKAGE.rglob("*.py")
                     if p.name != "__init__.py")
    missing = [m for m in modules if f"| `{m}` |" not in text]
    assert len(modules) >= 19
    assert not missing, f"modules missing from docs/bringup.md's code layout: {missing}"
