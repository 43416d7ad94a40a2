"""setup.sh's kernel step compiles or loads every compiled hot path of the suite."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

from phri_bringup import compile_kernels

ROOT = Path(__file__).resolve().parents[2]


def _modules_with_cached_kernels() -> set[str]:
    """Packages holding an ``@njit(cache=True...)`` function (read from the sources)."""
    found = set()
    for path in ROOT.glob("*/*/*.py"):
        if ".venv" in path.parts or "build" in path.parts or "install" in path.parts:
            continue
        tree = ast.parse(path.read_text())
        for node in ast.walk(tree):
            if isinstance(node, ast.FunctionDef) and any(
                "cache=True" in ast.unparse(d) for d in node.decorator_list
            ):
                found.add(path.parent.name)
    return found


def test_every_package_with_a_cached_kernel_is_compiled() -> None:
    compiled = {name.split()[0] for name in compile_kernels.KERNELS}
    assert _modules_with_cached_kernels() <= compiled


def test_main_names_each_kernel_it_readied(capsys: pytest.CaptureFixture[str]) -> None:
    compile_kernels.main()
    lines = capsys.readouterr().out.splitlines()
    assert [line.split(" ready")[0] for line in lines] == [
        f"compile_kernels: {name}" for name in compile_kernels.KERNELS]
