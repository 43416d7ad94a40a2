"""Launch files check the whole graph before starting anything (phri_bringup.graph.preflight)."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

from phri_bringup.graph import nodes as graph
from phri_bringup.graph import preflight

LAUNCH = Path(__file__).resolve().parents[1] / "launch"


def test_placeholders_are_found_with_their_node_and_parameter(tmp_path: Path) -> None:
    site = tmp_path / "site.yaml"
    site.write_text(
        "# header mentioning PLACEHOLDER in a comment line\n"
        "/left/ur_arm_bridge:\n"
        "  ros__parameters:\n"
        "    robot_ip: 10.0.0.1   # PLACEHOLDER: the address\n"
        "    rate_hz: 100.0\n"
        "/skin_driver_left:\n"
        "  ros__parameters:\n"
        "    layout_files:\n"
        "      - /etc/a.yaml   # PLACEHOLDER\n"
        "    port: /dev/x\n",
        encoding="utf-8")
    assert preflight.placeholders(site) == [(4, "/left/ur_arm_bridge", "robot_ip"),
                                            (9, "/skin_driver_left", "layout_files")]


def test_the_shipped_hardware_files_are_refused_until_edited() -> None:
    problems = preflight.placeholder_problems(graph.real_graph())
    ur_arms = str(graph.share_dir("phri_hardware") / "config" / "ur_arms.yaml")
    assert any(p.startswith(ur_arms) and "/left/ur_arm_bridge robot_ip" in p for p in problems)
    assert any("/right/ur_arm_bridge robot_ip" in p for p in problems)
    assert any("/skin_driver_left port" in p for p in problems)
    # A port given on the command line replaces the file's placeholder.
    given = preflight.placeholder_problems(graph.real_graph({"skin_driver_left": "/dev/ttyS1"}))
    assert not any("/skin_driver_left port" in p for p in given)
    assert len(given) == len(problems) - 1


def test_edited_copies_pass(tmp_path: Path) -> None:
    source = graph.share_dir("phri_hardware") / "config"
    for name in graph.HARDWARE_CONFIG.values():
        text = (source / name).read_text(encoding="utf-8")
        (tmp_path / name).write_text(text.replace("PLACEHOLDER", "set"), encoding="utf-8")
    assert preflight.placeholder_problems(graph.real_graph(hardware_dir=str(tmp_path))) == []


def test_missing_layouts_and_executables_are_reported(tmp_path: Path) -> None:
    (tmp_path / "left_upper_arm.yaml").write_text("x", encoding="utf-8")
    nodes = graph.real_graph(layout_dir=str(tmp_path))
    missing = preflight.missing_layouts(nodes)
    assert len(missing) == 2 and all("phri layouts" in m for m in missing)
    sim = graph.sim_graph("waltz")
    problems = preflight.launch_problems(sim, lambda pkg, exe: pkg != "robot_state_publisher")
    assert problems == ["/robot_state_publisher: executable 'robot_state_publisher' of "
                        "package 'robot_state_publisher' not found"]
    with pytest.raises(RuntimeError, match=r"sim.launch.py: nothing was started:\n.*"
                                           "robot_state_publisher"):
        preflight.refuse("sim.launch.py", problems)
    preflight.refuse("sim.launch.py", [])


def test_ament_lookup_of_an_absent_package_is_false() -> None:
    pytest.importorskip("ament_index_python")
    assert not preflight.ament_executable_exists("phri_no_such_package", "node")


@pytest.mark.parametrize("name", ["sim.launch.py", "real.launch.py"])
def test_launch_files_refuse_before_creating_any_node(name: str) -> None:
    """``_nodes`` returns the preflight action first, then the ``Node`` actions: launch executes
    a list in order, so a refusal comes before any process (and colcon lint, which evaluates
    ``_nodes`` without launching, still sees every node)."""
    tree = ast.parse((LAUNCH / name).read_text(encoding="utf-8"))
    func = next(f for f in tree.body if isinstance(f, ast.FunctionDef) and f.name == "_nodes")
    ret = next(n for n in ast.walk(func) if isinstance(n, ast.Return))
    assert isinstance(ret.value, ast.List) and len(ret.value.elts) == 2
    first, rest = ret.value.elts
    assert isinstance(first, ast.Name)
    assigned = next(n for n in ast.walk(func) if isinstance(n, ast.Assign)
                    and getattr(n.targets[0], "id", "") == first.id)
    assert getattr(assigned.value, "func", None) is not None
    assert assigned.value.func.id == "preflight_action"  # type: ignore[attr-defined]
    assert isinstance(rest, ast.Starred)
    assert any(getattr(c.func, "id", "") == "Node" for c in ast.walk(rest)
               if isinstance(c, ast.Call))
