"""Every package declares what it imports and starts; every package runs its tests under colcon.

The checks colcon lint and `colcon test` would make on a ROS install, made from the sources so
they run everywhere: imports (module, test and launch files, parsed with ``ast``) against each
``package.xml`` and the rosdep key table of docs/dependencies.md; ``package.xml`` validated with
catkin_pkg; each package's pytest configuration (``setup.cfg``) equal to the workspace's.
"""

from __future__ import annotations

import ast
import configparser
import re
import sys
import tomllib
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from phri_bringup.graph import nodes as graph

ROOT = Path(__file__).resolve().parents[2]
PACKAGES = sorted(p.parent.name for p in ROOT.glob("*/package.xml"))
ROS_MODULE = re.compile(r"^(rclpy|ament_index_python|launch\w*|\w+_(msgs|srvs|interfaces))$")
ALWAYS_TESTED_WITH = {"python3-pytest-timeout"}  # no import: setup.cfg's [tool:pytest] timeout


def _doc_keys() -> dict[str, str | None]:
    """import module → rosdep key (None: no key) from docs/dependencies.md's table."""
    text = (ROOT / "docs" / "dependencies.md").read_text(encoding="utf-8")
    keys: dict[str, str | None] = {}
    for line in text.splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) != 4 or not cells[0].startswith("`"):
            continue
        key = re.match(r"`([^`]+)`", cells[2])
        for module in re.findall(r"`([^`]+)`", cells[0]):
            keys[module] = key.group(1) if key else None
    return keys


def _imports(files: list[Path]) -> set[str]:
    found: set[str] = set()
    for f in files:
        for node in ast.walk(ast.parse(f.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Import):
                found |= {a.name.split(".")[0] for a in node.names}
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                found.add(node.module.split(".")[0])
            elif isinstance(node, ast.Call) and getattr(node.func, "attr", "") == "importorskip" \
                    and isinstance(node.args[0], ast.Constant):
                found.add(str(node.args[0].value).split(".")[0])
    return found - set(sys.stdlib_module_names) - {"__future__"}


def _declared(package: str) -> tuple[set[str], set[str]]:
    root = ET.parse(ROOT / package / "package.xml").getroot()
    run = {e.text or "" for tag in ("exec_depend", "depend") for e in root.iter(tag)}
    return run, {e.text or "" for e in root.iter("test_depend")}


def _key(module: str, keys: dict[str, str | None]) -> str | None:
    if module in PACKAGES or ROS_MODULE.match(module):
        return module
    assert module in keys, f"third-party import {module!r}: add it to docs/dependencies.md"
    return keys[module]


def _launched_packages() -> set[str]:
    nodes = graph.sim_graph("waltz", rviz=True) + graph.real_graph(rviz=True)
    recorded = {t.type.split("/")[0] for t in graph.SIM_TOPICS}  # observer/bag.py imports these
    processes = {n.package for n in nodes + graph.ros_nodes(nodes)} - {graph.PACKAGE}
    return processes | recorded | {"launch", "launch_ros"}


@pytest.mark.parametrize("package", PACKAGES)
def test_package_xml_declares_exactly_what_the_code_imports(package: str) -> None:
    keys = _doc_keys()
    run, test = _declared(package)
    src = list((ROOT / package / package).rglob("*.py")) + list(
        (ROOT / package).glob("launch/*.py"))
    tests = list((ROOT / package / "test").rglob("*.py"))
    local = {f.stem for f in tests}
    needed_run = {_key(m, keys) for m in _imports(src) - local} - {package, None}
    if package == graph.PACKAGE:
        needed_run |= _launched_packages()
    needed_test = {_key(m, keys) for m in _imports(tests) - local} - {package, None}
    assert sorted(needed_run - run) == [], f"{package}: add these <exec_depend>s"
    assert sorted(needed_test - run - test) == [], f"{package}: add these <test_depend>s"
    assert sorted(run - needed_run) == [], f"{package}: <exec_depend>s nothing uses"
    assert sorted(test - needed_test - ALWAYS_TESTED_WITH) == [], \
        f"{package}: <test_depend>s no test uses"
    assert test >= ALWAYS_TESTED_WITH


def test_keys_without_rosdep_entry_are_pip_installed_and_not_declared() -> None:
    keys = _doc_keys()
    requirements = (ROOT / "requirements.txt").read_text(encoding="utf-8")
    keyless = {m for m, k in keys.items() if k is None}
    assert keyless == {"daqp", "osqp", "rtde_control", "rtde_receive", "foxglove",
                       "imageio_ffmpeg"}
    for pip_name in ("daqp", "osqp", "ur-rtde", "foxglove-sdk", "imageio-ffmpeg"):
        assert re.search(rf"^{re.escape(pip_name)}[<>=]", requirements, re.M), pip_name
    for package in PACKAGES:
        run, test = _declared(package)
        assert not (run | test) & keyless


@pytest.mark.parametrize("package", PACKAGES)
def test_package_xml_is_valid_format_3(package: str) -> None:
    catkin_pkg = pytest.importorskip("catkin_pkg.package")
    warnings: list[str] = []
    parsed = catkin_pkg.parse_package(str(ROOT / package), warnings=warnings)
    parsed.validate(warnings=warnings)
    assert parsed.package_format == 3 and parsed.name == package
    assert warnings == []
    assert parsed.exports[0].tagname == "build_type"
    assert parsed.exports[0].content == "ament_python"


@pytest.mark.parametrize("package", PACKAGES)
def test_package_xml_names_each_dependency_once(package: str) -> None:
    """A key twice (catkin_pkg accepts it; colcon lint and reviewers do not) is a merge slip."""
    import xml.etree.ElementTree as ET

    root = ET.parse(ROOT / package / "package.xml").getroot()
    kinds = ("depend", "build_depend", "build_export_depend", "exec_depend", "test_depend")
    seen: dict[tuple[str, str], int] = {}
    for element in root:
        if element.tag in kinds and element.text:
            key = (element.tag, element.text.strip())
            seen[key] = seen.get(key, 0) + 1
    assert [k for k, n in seen.items() if n > 1] == []


@pytest.mark.parametrize("package", PACKAGES)
def test_colcon_runs_pytest_with_the_workspace_options(package: str) -> None:
    """colcon picks pytest (not unittest, which finds 0 tests) only when setup.cfg's ``test``
    extra names it, and runs it in the package directory: the ``[tool:pytest]`` section there
    must carry the root pyproject.toml's options."""
    cfg = configparser.ConfigParser()
    cfg.read(ROOT / package / "setup.cfg", encoding="utf-8")
    assert "pytest" in cfg["options.extras_require"]["test"].split()
    local = cfg["tool:pytest"]
    root = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))
    options = root["tool"]["pytest"]["ini_options"]
    assert local["testpaths"].split() == ["test"]
    assert f"{package}/test" in options["testpaths"]
    assert local["addopts"] == options["addopts"]
    assert float(local["timeout"]) == options["timeout"]
    assert [m.strip() for m in local["markers"].strip().splitlines()] == options["markers"]
    assert local["filterwarnings"].split() == options["filterwarnings"]


DATA_FOLDERS = ("config", "launch", "rviz", "urdf", "meshes", "layouts")
"""Folders of a package whose files a ROS install must find in ``share/<package>/``."""


@pytest.mark.parametrize("package", PACKAGES)
def test_every_data_file_is_installed_to_the_share_directory(package: str) -> None:
    """A plain ``colcon build`` copies only what ``[options.data_files]`` lists: a data file left
    out exists in the source tree (and so for an editable install) but not in
    ``install/<package>/share`` — where nodes, launch files and tests of a ROS install look."""
    cfg = configparser.ConfigParser()
    cfg.read(ROOT / package / "setup.cfg", encoding="utf-8")
    installed = {}
    for target, sources in cfg["options.data_files"].items():
        for source in re.split(r"[,\s]+", sources.strip()):
            if source:
                installed[source] = target
    for folder in DATA_FOLDERS:
        for path in sorted((ROOT / package / folder).glob("*")):
            relative = f"{folder}/{path.name}"
            assert installed.get(relative) == f"share/{package}/{folder}", (
                f"{package}/setup.cfg [options.data_files] must install {relative} to "
                f"share/{package}/{folder}")
