"""The launch files and the in-process runner describe the same nodes and parameters."""

from __future__ import annotations

import ast
from pathlib import Path
from typing import Any

import pytest

from phri_bringup.graph import nodes as graph
from phri_bringup.graph import parameter_files as params

LAUNCH = Path(__file__).resolve().parents[1] / "launch"


def _launch_tree(name: str) -> ast.Module:
    return ast.parse((LAUNCH / name).read_text(encoding="utf-8"))


@pytest.mark.parametrize(("name", "builder"), [("sim.launch.py", "sim_graph"),
                                                ("real.launch.py", "real_graph")])
def test_launch_files_build_their_nodes_from_the_graph_module(name: str, builder: str) -> None:
    tree = _launch_tree(name)
    imported = {alias.name for node in ast.walk(tree) if isinstance(node, ast.ImportFrom)
                and node.module == "phri_bringup.graph.nodes" for alias in node.names}
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
    specs = graph.sim_graph("wholebody", rviz=True) + graph.real_graph(rviz=True) + \
        graph.real_graph(skin_process="separate")
    for spec in specs:
        kwargs = graph.launch_node_kwargs(spec, urdf="<robot/>")
        if spec.nodes:  # a multi-node process: every node's files, no __node rename
            assert "name" not in kwargs and kwargs["executable"] == spec.executable
            for node in spec.nodes:
                for f in node.parameter_files:
                    assert str(graph.config_file(f)) in kwargs["parameters"]
                    assert node.name in params.load(graph.config_file(f)), (node.name, f)
            continue
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


@pytest.mark.parametrize("skin_process", graph.SKIN_PROCESSES)
def test_real_graph_references_the_hardware_nodes(skin_process: str) -> None:
    nodes = graph.ros_nodes(graph.real_graph({"skin_driver_left": "/dev/ttyUSB7"},
                                             skin_process=skin_process))
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
    nodes = graph.ros_nodes(graph.real_graph(base_cmd_topic="/platform/cmd_vel"))
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
    nodes = graph.ros_nodes(graph.real_graph(layout_dir="layouts",
                                             hardware_dir=str(tmp_path / "site")))
    files = [Path(f) for n in nodes if n.package == "skin_driver"
             for f in n.parameters["layout_files"]]
    assert sorted(f.stem for f in files) == sorted(graph.PATCHES)
    assert all(f.is_absolute() and f.parent == tmp_path / "layouts" for f in files)
    arm = next(n for n in nodes if n.name == "ur_arm_bridge")
    assert arm.parameter_files == (str(tmp_path / "site" / "ur_arms.yaml"),)


def test_skin_process_composed_or_separate_holds_the_same_nodes() -> None:
    """Composed, the drivers and the estimator are one skin_contact_node process whose
    ``--drivers`` are the driver nodes; separate, one process each; the nodes, their files and
    their parameters are the same either way except the composed drivers' taxel rate."""
    composed = graph.real_graph({"skin_driver_left": "/dev/ttyUSB7"}, taxel_rate_hz=25.0)
    separate = graph.real_graph({"skin_driver_left": "/dev/ttyUSB7"}, skin_process="separate")
    assert graph.DEFAULT_SKIN_PROCESS == "composed"
    process = next(s for s in composed if s.nodes)
    assert (process.package, process.executable) == ("phri_bringup", "skin_contact_node")
    drivers = list(graph.REAL_SKIN_PORTS)
    assert list(process.arguments) == ["--drivers", *drivers]
    assert [n.name for n in process.nodes] == [*drivers, graph.ESTIMATION]
    assert not any(s.nodes for s in separate)
    assert len(separate) == len(composed) + len(drivers)
    by_composed = {n.name: n for n in graph.ros_nodes(composed)}
    by_separate = {n.name: n for n in graph.ros_nodes(separate)}
    assert set(by_composed) == set(by_separate)
    for name in drivers:
        assert by_composed[name].parameters == {**by_separate[name].parameters,
                                                "taxel_publish_rate_hz": 25.0}
        assert "taxel_publish_rate_hz" not in by_separate[name].parameters
    assert by_composed[graph.ESTIMATION] == by_separate[graph.ESTIMATION]
    with pytest.raises(ValueError, match="skin_process refused 'fused'"):
        graph.real_graph(skin_process="fused")
    with pytest.raises(ValueError, match="taxel_rate_hz refused -1"):
        graph.real_graph(taxel_rate_hz=-1.0)


def test_composed_process_kwargs_scope_inline_parameters_to_their_node() -> None:
    """A ``__node`` remap would rename every node in the process, and an unscoped inline
    parameter would reach every node: the kwargs have neither."""
    spec = next(s for s in graph.real_graph({"skin_driver_right": "/dev/ttyS3"},
                                            layout_dir="/site/layouts") if s.nodes)
    kwargs = graph.launch_node_kwargs(spec)
    assert "name" not in kwargs and "remappings" not in kwargs
    assert all(isinstance(p, str) for p in kwargs["parameters"])
    assert kwargs["arguments"] == ["--drivers", *graph.REAL_SKIN_PORTS]
    scoped = kwargs["ros_arguments"]
    assert scoped[::2] == ["-p"] * (len(scoped) // 2)
    assert '-p' not in scoped[1::2]
    assert 'skin_driver_right:port:="/dev/ttyS3"' in scoped
    assert "skin_driver_left:port:=" not in " ".join(scoped)
    assert 'skin_driver_right:layout_files:=["/site/layouts/right_forearm.yaml"]' in scoped
    assert f"skin_driver_left:taxel_publish_rate_hz:={graph.DEFAULT_TAXEL_RATE_HZ}" in scoped
    assert not [a for a in scoped[1::2] if a.split(":")[0] not in graph.REAL_SKIN_PORTS]


def test_rviz_runs_on_sim_time_in_the_simulation() -> None:
    sim_rviz = graph.launch_node_kwargs(graph.sim_graph("waltz", rviz=True)[-1])
    real_rviz = graph.launch_node_kwargs(graph.real_graph(rviz=True)[-1])
    assert sim_rviz["executable"] == real_rviz["executable"] == "rviz2"
    assert sim_rviz["parameters"] == [{"use_sim_time": True}]
    assert real_rviz["parameters"] == [{"use_sim_time": False}]
    assert Path(sim_rviz["arguments"][1]).is_file()


def test_scenario_names_map_to_phri_sim() -> None:
    from phri_sim.scenarios.catalogue import SCENARIOS

    for cli in ("centring", "sliding", "wholebody", "waltz"):
        assert graph.canonical_scenario(cli) in SCENARIOS
    assert set(graph.SCENARIO_FILES) == set(SCENARIOS)
    with pytest.raises(ValueError, match="known"):
        graph.canonical_scenario("tango")


@pytest.mark.ros
@pytest.mark.parametrize("scenario", ["waltz", "sliding"])
def test_runner_nodes_and_parameters_match_the_graph(ros_context: Any, scenario: str) -> None:
    """The in-process nodes are the graph's in-process nodes and hold the file's values."""
    from phri_bringup.cli.session import run_session
    from phri_sim.ros.run_options import RunOptions

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

    result = run_session(scenario, RunOptions(duration=0.05), context=ros_context, inspect=inspect)
    assert set(seen) == {s.name for s in specs}
    assert len(seen[graph.CONTROLLER]) > 10
    assert result.zero_at_exit


@pytest.mark.parametrize("name", ["sim.launch.py", "real.launch.py"])
def test_every_launch_argument_is_documented(name: str) -> None:
    """docs/bringup.md's launch argument table names every DeclareLaunchArgument."""
    declared = {c.args[0].value for c in ast.walk(_launch_tree(name))
                if isinstance(c, ast.Call) and getattr(c.func, "id", "") ==
                "DeclareLaunchArgument" and isinstance(c.args[0], ast.Constant)}
    docs = (Path(__file__).resolve().parents[2] / "docs" / "bringup.md").read_text("utf-8")
    rows = {cell.strip("` ") for line in docs.splitlines() if line.startswith("| `")
            for cell in line.split("|")[1].split("(")[0].split(",")}
    assert declared and declared <= rows, declared - rows


def test_ur_robot_driver_replaces_the_arm_bridges_and_nothing_else() -> None:
    """``arm_driver:=ur_robot_driver``: no phri arm bridge (and so none of ur_arms.yaml's
    placeholders in the way); every other node as with phri's RTDE bridges; the launch file
    offers exactly the graph's choices."""
    from phri_bringup.cli.main import main
    from phri_bringup.graph.preflight import placeholder_problems

    rtde = graph.ros_nodes(graph.real_graph())
    urd = graph.ros_nodes(graph.real_graph(arm_driver="ur_robot_driver"))
    assert [(n.namespace, n.name) for n in rtde if n.name != "ur_arm_bridge"] == \
        [(n.namespace, n.name) for n in urd]
    assert {(n.namespace, n.name) for n in rtde} - {(n.namespace, n.name) for n in urd} == \
        {("left", "ur_arm_bridge"), ("right", "ur_arm_bridge")}
    assert any("ur_arms.yaml" in p for p in placeholder_problems(graph.real_graph()))
    assert not any("ur_arms.yaml" in p for p in placeholder_problems(urd))
    with pytest.raises(ValueError, match="arm_driver"):
        graph.real_graph(arm_driver="ur_rtde_driver")
    tree = _launch_tree("real.launch.py")
    declared = [c for c in ast.walk(tree) if isinstance(c, ast.Call)
                and getattr(c.func, "id", "") == "DeclareLaunchArgument"
                and isinstance(c.args[0], ast.Constant) and c.args[0].value == "arm_driver"]
    assert len(declared) == 1
    keywords = {k.arg: k.value for k in declared[0].keywords}
    assert getattr(keywords["choices"], "args", [None])[0].id == "ARM_DRIVERS"  # type: ignore[union-attr]
    assert main(["graph", "real", "--arm-driver", "ur_robot_driver"]) == 0
