"""Checks a launch file runs before it starts any process (pure: no rclpy, no launch).

A launch that fails half-way (a package not installed, an executable missing, a site-specific
value still at its placeholder) used to leave the nodes it had already started running as
orphans. ``sim.launch.py`` and ``real.launch.py`` therefore check the whole graph first and start
nothing when :func:`launch_problems` reports anything; the error names the file to edit.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

from phri_bringup.graph.nodes import NodeSpec, config_file, ros_nodes

PLACEHOLDER = "PLACEHOLDER"
"""Marker in a phri_hardware parameter file's comment: the value must be set for the robot."""

_SECTION = re.compile(r"^(/?[\w/]+):\s*(#.*)?$")
_KEY = re.compile(r"^\s+(\w+):")
_ITEM = re.compile(r"^\s+-\s")


def placeholders(path: Path) -> list[tuple[int, str, str]]:
    """(line number, node section, parameter) of every value marked ``# PLACEHOLDER``.

    A list item's mark counts for the list's parameter. Sections are the file's top-level keys
    (fully qualified node names such as ``/left/ur_arm_bridge``)."""
    found = []
    section, key = "", ""
    for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), start=1):
        head = _SECTION.match(line)
        if head:
            section, key = head.group(1), ""
            continue
        name = _KEY.match(line)
        if name and not _ITEM.match(line):
            key = name.group(1)
        comment = line.partition("#")[2]
        if PLACEHOLDER in comment and key and key != "ros__parameters":
            found.append((number, section, key))
    return found


def _node_path(spec: NodeSpec) -> str:
    return f"/{spec.namespace}/{spec.name}" if spec.namespace else f"/{spec.name}"


def placeholder_problems(graph: Iterable[NodeSpec]) -> list[str]:
    """One line per placeholder value a node of ``graph`` would get from its parameter files
    (values the launch arguments override, e.g. a skin ``port``, do not count)."""
    problems = []
    for spec in ros_nodes(list(graph)):
        for entry in spec.parameter_files:
            path = config_file(entry)
            for number, section, key in placeholders(path):
                if section.lstrip("/") == _node_path(spec).lstrip("/") and \
                        key not in spec.parameters:
                    problems.append(f"{path}:{number}: {section} {key} is still a placeholder "
                                    f"(marked {PLACEHOLDER}): set it for your robot and delete "
                                    "the mark")
    return problems


def missing_layouts(graph: Iterable[NodeSpec]) -> list[str]:
    """Skin layout files given on the launch command line that do not exist."""
    return [f"skin layout {f} does not exist (`phri layouts DIR` writes nominal ones)"
            for spec in ros_nodes(list(graph)) for f in spec.parameters.get("layout_files", [])
            if not Path(f).is_file()]


def missing_executables(graph: Iterable[NodeSpec],
                        exists: Callable[[str, str], bool]) -> list[str]:
    """Nodes whose ``(package, executable)`` is not installed, by ``exists(package, exe)``."""
    return [f"{_node_path(s)}: executable {s.executable!r} of package {s.package!r} not found"
            for s in graph if not exists(s.package, s.executable)]


def ament_executable_exists(package: str, executable: str) -> bool:
    """``ros2 run``'s lookup: ``<prefix>/lib/<package>/<executable>`` of the package's prefix in
    the ament index (AMENT_PREFIX_PATH)."""
    from ament_index_python.packages import PackageNotFoundError, get_package_prefix

    try:
        prefix = Path(get_package_prefix(package))
    except (PackageNotFoundError, ValueError, OSError):  # OSError: AMENT_PREFIX_PATH unset
        return False
    return (prefix / "lib" / package / executable).is_file()


def launch_problems(graph: list[NodeSpec], exists: Callable[[str, str], bool],
                    real: bool = False) -> list[str]:
    """Everything that would make the launch fail: missing executables, and on the real robot
    placeholders and missing layout files."""
    problems = missing_executables(graph, exists)
    if real:
        problems += placeholder_problems(graph) + missing_layouts(graph)
    return problems


def refuse(launch_file: str, problems: list[str]) -> None:
    """Raise one error listing every problem, before any process is started.

    Raises:
        RuntimeError: when ``problems`` is not empty.
    """
    if problems:
        raise RuntimeError(f"{launch_file}: nothing was started:\n  " + "\n  ".join(problems))


def preflight_action(launch_file: str, problems: Callable[[], list[str]]) -> Any:
    """A launch action that calls :func:`refuse` with ``problems()`` when it is executed.

    The launch files return it first, before their ``Node`` actions: launch executes the
    entities of a list in order, so a refusal stops the launch before any process starts. It is
    an action of its own rather than a check inside the ``OpaqueFunction`` so that tools that
    evaluate launch files without launching (colcon lint) still see every ``Node``."""
    from launch.action import Action

    class Preflight(Action):
        def execute(self, context: Any) -> None:
            del context
            refuse(launch_file, problems())

    return Preflight()
