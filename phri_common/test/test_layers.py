"""The layer check of phri_common.testing on a small made-up package."""

from __future__ import annotations

from pathlib import Path

from phri_common.testing import layer_violations


def _package(root: Path, files: dict[str, str]) -> Path:
    pkg = root / "pkg"
    for name, text in {"__init__.py": "", **files}.items():
        path = pkg / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text, encoding="utf-8")
    return pkg


def test_imports_down_or_within_a_layer_pass(tmp_path: Path) -> None:
    pkg = _package(tmp_path, {
        "low/__init__.py": "", "low/a.py": "import numpy\n",
        "high/__init__.py": "", "high/b.py": "from pkg.low.a import x\nimport pkg.high.c\n",
        "high/c.py": "def f():\n    from pkg.low import a\n",
        "main.py": "from pkg.high.b import y\n",
    })
    assert layer_violations(pkg, ("low", "high")) == []


def test_upward_imports_are_named_also_inside_functions(tmp_path: Path) -> None:
    pkg = _package(tmp_path, {
        "low/__init__.py": "", "low/a.py": "def f():\n    from pkg.high.b import y\n",
        "low/c.py": "from pkg.high import b\n", "low/d.py": "import pkg.main\n",
        "high/__init__.py": "", "high/b.py": "import other\n",
        "main.py": "",
    })
    problems = layer_violations(pkg, ("low", "high"), above=("other",))
    assert problems == [
        "high/b.py: imports other (package other is above)",
        "low/a.py: imports pkg.high.b (layer high is above low)",
        "low/c.py: imports pkg.high (layer high is above low)",
        "low/d.py: imports pkg.main (a top-level module)",
    ]


def test_a_subpackage_missing_from_the_layers_is_reported(tmp_path: Path) -> None:
    pkg = _package(tmp_path, {"low/__init__.py": "", "extra/__init__.py": ""})
    assert layer_violations(pkg, ("low",)) == ["extra/ is not in the layer list"]
