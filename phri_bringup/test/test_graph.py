"""The launch files and the in-process runner describe the same nodes and parameters."""

from __future__ import annotations

import ast
from pathlib import Path
from typing import Any

import pytest

from phri_bringup import graph, params

LAUNCH = Path(__file__).resolve().parents[1] / "launch"


def _launch_tree(name: str) -> ast.Module:
    return ast.parse((LAUNCH / name).read_text(encoding="utf-8"))


@pytest.mark.parametrize(("name", "builder"), [("sim.launch.py", "sim_graph"),
                                                ("real.launch.py", "real_graph")])
def test_launch_files_build_their_nodes_from_the_graph_module(name: str, builder: str) -> None:
    tree = _launch_tree(name)
    imported = {alias.name for node in ast.walk(tree) if isinstance(node, ast.ImportFrom)
                and node.module == "phri_bringup.graph" for alias in node.names}
    assert {builder, "launch_node_kwargs"} <= imported
    names = {n.id for n in ast.walk(tree) if isinstance(n, ast.Name)}
    assert "generate_launch_description" in {f.name for f in tree.body
                                              if isinstance(f, ast.FunctionDef)}
    assert builder in names
    # No node is described in the launch file itself: Node() only takes the graph's kwargs.
    for call in ast.walk(tree):
        if isinstance(call, ast.Call) and getattr(call.func, "id", "") == "Node":
            assert not call.args and len(call.keywords) == 1 and call.keywords[0].arg is None
    literals = {c.value for c in ast.walk(tree) if isinstance(c, ast.Constant)}
    for spec in graph.sim_graph("waltz") + graph.real_graph():
        assert spec.executable not in literals or spec.executable == spec.package


def test_launch_kwargs_point_at_existing_parameter_files() -> None:
    for spec in graph.sim_graph("wholebody", rviz=True) + graph.real_graph(rviz=True):
        kwargs = graph.launch_node_kwargs(spec, urdf="<robot/>")
        assert kwargs["executable"] == spec.executable and kwargs["name"] == spec.name
        if spec.package == "rviz2":
            assert Path(kwargs["arguments"][1]).is_file()
            continue
        files = [p for p in kwargs["parameters"] if isinstance(p, str)]
        assert all(Path(p).is_file() for p in files)
        node_path = f"{spec.namespace}/{spec.name}" if spec.namespace else spec.name
        for f in files:
            assert node_path in params.load(Path(f)), (node_path, f)
        inline = [p for p in kwargs["parameters"] if isinstance(p, dict)]
        if spec.name == graph.ROBOT_STATE_PUBLISHER:
            assert inline[0]["robot_description"] == "<robot/>"


def test_real_graph_references_the_hardware_nodes() -> None:
    nodes = graph.real_graph({"skin_driver_left": "/dev/ttyUSB7"})
    by = {(n.namespace, n.name): n for n in nodes}
    assert by[("left", "ur_arm_bridge")].executable == "ur_arm_bridge_node"
    assert by[("right", "ur_arm_bridge")].package == "phri_hardware"
    assert by[("", "base_guard")].executable == "base_guard_node"
    assert by[("", "skin_driver_left")].parameters["port"] == "/dev/ttyUSB7"
    assert "port" not in by[("", "skin_driver_right")].parameters  # skin_real.yaml's
    assert graph.ROBOT_STATE_PUBLISHER in {n.name for n in nodes}


def test_real_graph_loads_phri_hardware_configs_and_remaps_the_base() -> None:
    """Every hardware node gets its phri_hardware file first (then real.yaml), so the arm
    bridges see a robot_ip and the skin drivers a port and layouts; the base guard's output goes
    to the driver topic given on the command line."""
    nodes = graph.real_graph(base_cmd_topic="/platform/cmd_vel")
    share = graph.share_dir("phri_hardware") / "config"
    for n in nodes:
        if n.package in ("phri_hardware", "skin_driver"):
            files = [Path(f) for f in graph.launch_node_kwargs(n)["parameters"]
                     if isinstance(f, str)]
            assert files[0].parent == share, n.name
            node_path = f"{n.namespace}/{n.name}" if n.namespace else n.name
            assert params.load(files[0])[node_path], node_path
    by = {(n.namespace, n.name): n for n in nodes}
    assert ("base/cmd_vel", "/platform/cmd_vel") in by[("", "base_guard")].remappings
    arm = graph.launch_node_kwargs(by[("left", "ur_arm_bridge")])
    assert params.load(Path(arm["parameters"][0]))["left/ur_arm_bridge"]["robot_ip"]


def test_real_graph_layout_dir_is_made_absolute(tmp_path: Path, monkeypatch: Any) -> None:
    monkeypatch.chdir(tmp_path)
    nodes = graph.real_graph(layout_dir="layouts", hardware_dir=str(tmp_path / "site"))
    files = [Path(f) for n in nodes if n.package == "skin_driver"
             for f in n.parameters["layout_files"]]
    assert sorted(f.stem for f in files) == sorted(graph.PATCHES)
    assert all(f.is_absolute() and f.parent == tmp_path / "layouts" for f in files)
    arm = next(n for n in nodes if n.name == "ur_arm_bridge")
    assert arm.parameter_files == (str(tmp_path / "site" / "ur_arms.yaml"),)


def test_rviz_runs_on_sim_time_in_the_simulation() -> None:
    sim_rviz = graph.launch_node_kwargs(graph.sim_graph("waltz", rviz=True)[-1])
    real_rviz = graph.launch_node_kwargs(graph.real_graph(rviz=True)[-1])
    assert sim_rviz["executable"] == real_rviz["executable"] == "rviz2"
    assert sim_rviz["parameters"] == [{"use_sim_time": True}]
    assert real_rviz["parameters"] == [{"use_sim_time": False}]
    assert Path(sim_rviz["arguments"][1]).is_file()


def test_scenario_names_map_to_phri_sim() -> None:
    from phri_sim.scenarios import SCENARIOS

    for cli in ("centring", "sliding", "wholebody", "waltz"):
        assert graph.canonical_scenario(cli) in SCENARIOS
    assert set(graph.SCENARIO_FILES) == set(SCENARIOS)
    with pytest.raises(ValueError, match="known"):
        graph.canonical_scenario("tango")


@pytest.mark.ros
@pytest.mark.parametrize("scenario", ["waltz", "sliding"])
def test_runner_nodes_and_parameters_match_the_graph(ros_context: Any, scenario: str) -> None:
    """The in-process nodes are the graph's in-process nodes and hold the file's values."""
    from phri_bringup.session import run_session

    specs = [n for n in graph.sim_graph(scenario) if n.in_process]
    sections = params.load(graph.config_file(graph.scenario_file(scenario)))
    seen: dict[str, dict[str, Any]] = {}

    def inspect(run: Any) -> None:
        nodes = {n.get_name(): n for n in (run.bridge, run.estimation, run.controller)}
        assert set(nodes) == {s.name for s in specs}
        for spec in specs:
            node = nodes[spec.name]
            expected = {**sections.get(spec.name, {}), **spec.parameters,
                        **graph.LOCKSTEP_OVERRIDES.get(spec.name, {})}
            seen[spec.name] = expected
            for key, value in expected.items():
                actual = node.get_parameter(key).value
                if isinstance(value, list):
                    assert list(actual) == pytest.approx(value), (spec.name, key)
                else:
                    assert actual == value, (spec.name, key)

    result = run_session(scenario, duration=0.05, context=ros_context, inspect=inspect)
    assert set(seen) == {s.name for s in specs}
    assert len(seen[graph.CONTROLLER]) > 10
    assert result.zero_at_exit
