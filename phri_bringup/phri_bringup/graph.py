"""THE description of phri's node graph (pure Python: no rclpy, no launch).

``sim.launch.py``, ``real.launch.py`` and the in-process runner behind ``phri sim`` are all built
from the lists below, so the nodes, executables, namespaces, parameter files and remappings
cannot drift apart (``test_graph.py`` checks the launch files against this module and the
running in-process nodes against the parameter files).

A :class:`NodeSpec` names a node the way ``launch_ros.actions.Node`` wants it (package,
executable, name, namespace, parameter files, inline parameters, remappings); ``in_process``
marks the nodes that the lock-step runner also creates in one process (the robot state publisher
and rviz exist only on a ROS install).

It also lists the documented topics with their types (:data:`SIM_TOPICS`), which the recorder
subscribes and the tests expect in a recording.
"""

from __future__ import annotations

import os
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from phri_description.description import SIDES, SKIN_LINKS, SKIN_PATCHES

PACKAGE = "phri_bringup"

SCENARIO_ALIASES: dict[str, str] = {
    "centring": "centring",
    "centering": "centring",
    "sliding": "sliding",
    "tracking": "sliding",
    "wholebody": "whole_body",
    "whole_body": "whole_body",
    "whole-body": "whole_body",
    "waltz": "waltz",
}
"""Command-line scenario names → phri_sim scenario names."""

SCENARIO_FILES: dict[str, str] = {
    "centring": "centring",
    "sliding": "sliding",
    "whole_body": "wholebody",
    "waltz": "waltz",
}
"""phri_sim scenario name → parameter file stem in ``config/``."""

PATCHES: tuple[str, ...] = SKIN_PATCHES
"""Skin patches, in description order; :data:`SKIN_LINKS` (imported from the robot description)
are the links that carry them (one contact state each)."""
ARMS: tuple[str, ...] = SIDES

BRIDGE = "phri_sim"
ESTIMATION = "contact_estimation"
CONTROLLER = "wholebody_controller"
ROBOT_STATE_PUBLISHER = "robot_state_publisher"

LOCKSTEP_OVERRIDES: dict[str, dict[str, Any]] = {
    BRIDGE: {"lockstep": True, "skin_rate_hz": 100.0},
    CONTROLLER: {"contact_timeout": 2.0, "joint_state_timeout": 2.0, "odom_timeout": 2.0},
}
"""Values the lock-step runner sets instead of the parameter file's (phri_sim.runner: one skin
frame per control period; the controller's wall-clock input timeouts loosened so a loaded machine
cannot trip them — the bridge's sim-time watchdog still applies)."""


@dataclass(frozen=True)
class NodeSpec:
    """One node of the graph, as ``launch_ros.actions.Node`` takes it.

    Attributes:
        name: node name (also the key of its section in the parameter files).
        package, executable: what ``ros2 run`` starts.
        namespace: '' or e.g. ``left``.
        parameter_files: ``config/`` file stems whose ``<name>:`` section applies (the launch
            file passes the files; the runner loads the same sections).
        parameters: inline parameters (launch arguments resolved by the caller).
        remappings: (from, to) topic pairs.
        in_process: the lock-step runner also creates this node in one process.
        description: one line for listings and the docs.
    """

    name: str
    package: str
    executable: str
    namespace: str = ""
    parameter_files: tuple[str, ...] = ()
    parameters: dict[str, Any] = field(default_factory=dict)
    remappings: tuple[tuple[str, str], ...] = ()
    in_process: bool = False
    description: str = ""


@dataclass(frozen=True)
class TopicSpec:
    """A documented topic: fully qualified name and ROS type (``pkg/msg/Type``)."""

    name: str
    type: str


def canonical_scenario(name: str) -> str:
    """Command-line or phri_sim scenario name → phri_sim name.

    Raises:
        ValueError: unknown name (the message lists the known ones).
    """
    try:
        return SCENARIO_ALIASES[name]
    except KeyError:
        known = ", ".join(sorted(set(SCENARIO_FILES.values())))
        raise ValueError(f"unknown scenario {name!r}; known: {known}") from None


def scenario_file(name: str) -> str:
    """Parameter file stem of a scenario (any accepted spelling)."""
    return SCENARIO_FILES[canonical_scenario(name)]


def share_dir() -> Path:
    """Directory holding ``config/``, ``launch/`` and ``rviz/``: the source tree for an editable
    install, else ``<prefix>/share/phri_bringup`` (pip data files or a colcon install)."""
    source = Path(__file__).resolve().parent.parent
    if (source / "config").is_dir():
        return source
    candidates = [Path(sys.prefix) / "share" / PACKAGE]
    for prefix in os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep):
        if prefix:
            candidates.append(Path(prefix) / "share" / PACKAGE)
    for candidate in candidates:
        if (candidate / "config").is_dir():
            return candidate
    raise FileNotFoundError(f"{PACKAGE}: no config directory found (looked in {source} and "
                            f"{', '.join(str(c) for c in candidates)})")


def config_file(stem: str) -> Path:
    """Path of ``config/<stem>.yaml``."""
    return share_dir() / "config" / f"{stem}.yaml"


def sim_graph(scenario: str, seed: int = 0, rviz: bool = False) -> list[NodeSpec]:
    """Nodes of the simulated robot running ``scenario`` (any accepted spelling)."""
    stem = scenario_file(scenario)
    sim_time = {"use_sim_time": True}
    nodes = [
        NodeSpec(BRIDGE, "phri_sim", "phri_sim_bridge", parameter_files=(stem,),
                 parameters={"seed": seed}, in_process=True,
                 description="MuJoCo robot, skins and person behind the hardware topics"),
        NodeSpec(ESTIMATION, "contact_estimation", "contact_estimation_node",
                 parameter_files=(stem,), parameters=dict(sim_time), in_process=True,
                 description="taxel arrays → one contact state per link (eq. 5, 9)"),
        NodeSpec(CONTROLLER, "wholebody_controller", "wholebody_controller_node",
                 parameter_files=(stem,), parameters=dict(sim_time), in_process=True,
                 description="admittance, priorities, QP → base twist and arm velocities"),
        NodeSpec(ROBOT_STATE_PUBLISHER, "robot_state_publisher", "robot_state_publisher",
                 parameters={**sim_time, "robot_description": "<URDF>"},
                 description="TF of every link from /joint_states (URDF of phri_description)"),
    ]
    if rviz:
        nodes.append(rviz_node())
    return nodes


def rviz_node() -> NodeSpec:
    """rviz2 with ``rviz/phri.rviz``."""
    return NodeSpec("rviz2", "rviz2", "rviz2", parameters={"config": "rviz/phri.rviz"},
                    description="robot, taxel clouds and contacts")


REAL_SKIN_PORTS: dict[str, tuple[str, tuple[str, ...]]] = {
    f"skin_driver_{side}": (port, tuple(p for p in SKIN_PATCHES if p.startswith(f"{side}_")))
    for side, port in zip(SIDES, ("/dev/ttyACM0", "/dev/ttyACM1"), strict=True)
}
"""Real skin wiring: driver node → (default port, patches on that port in board-id order)."""


def real_graph(ports: dict[str, str] | None = None, layout_dir: str = "config/skin",
               rviz: bool = False) -> list[NodeSpec]:
    """Nodes on the real robot: skin drivers on their serial ports, estimation, controller, the
    phri_hardware arm bridges (namespaces ``left``/``right``) and base guard, and the robot
    state publisher. ``ports`` overrides the default port of a skin driver node."""
    ports = ports or {}
    nodes = []
    for name, (port, patches) in REAL_SKIN_PORTS.items():
        nodes.append(NodeSpec(
            name, "skin_driver", "skin_driver_node", parameter_files=("real",),
            parameters={
                "port": ports.get(name, port),
                "board_ids": list(range(len(patches))),
                "layout_files": [f"{layout_dir}/{p}.yaml" for p in patches],
            },
            description=f"skin boards of {', '.join(patches)} over a serial port",
        ))
    nodes += [
        NodeSpec(ESTIMATION, "contact_estimation", "contact_estimation_node",
                 parameter_files=("real",), description="contact state per link"),
        NodeSpec(CONTROLLER, "wholebody_controller", "wholebody_controller_node",
                 parameter_files=("real",), description="whole-body admittance QP"),
        *(NodeSpec("ur_arm_bridge", "phri_hardware", "ur_arm_bridge_node", namespace=arm,
                   description=f"{arm} UR16e: forward_velocity_controller/commands → RTDE "
                               "speedJ, joint states")
          for arm in ARMS),
        NodeSpec("base_guard", "phri_hardware", "base_guard_node",
                 description="/cmd_vel watchdog and limits in front of the base driver"),
        NodeSpec(ROBOT_STATE_PUBLISHER, "robot_state_publisher", "robot_state_publisher",
                 parameters={"robot_description": "<URDF>"}, description="TF of every link"),
    ]
    if rviz:
        nodes.append(rviz_node())
    return nodes


SIM_TOPICS: tuple[TopicSpec, ...] = (
    *(TopicSpec(f"/skin/{p}/taxels", "sensor_msgs/msg/PointCloud2") for p in PATCHES),
    *(TopicSpec(f"/contacts/{link}", "sensor_msgs/msg/PointCloud2") for link in SKIN_LINKS),
    TopicSpec("/contacts/markers", "visualization_msgs/msg/MarkerArray"),
    TopicSpec("/joint_states", "sensor_msgs/msg/JointState"),
    TopicSpec("/odom", "nav_msgs/msg/Odometry"),
    TopicSpec("/clock", "rosgraph_msgs/msg/Clock"),
    TopicSpec("/cmd_vel", "geometry_msgs/msg/Twist"),
    *(TopicSpec(f"/{arm}/forward_velocity_controller/commands", "std_msgs/msg/Float64MultiArray")
      for arm in ARMS),
    *(TopicSpec(f"/{CONTROLLER}/state/{link}", "sensor_msgs/msg/PointCloud2")
      for link in SKIN_LINKS),
    *(TopicSpec(f"/sim/contacts/{link}/wrench", "geometry_msgs/msg/WrenchStamped")
      for link in SKIN_LINKS),
    *(TopicSpec(f"/sim/contacts/{link}/center", "geometry_msgs/msg/PointStamped")
      for link in SKIN_LINKS),
    TopicSpec("/sim/person/poses", "geometry_msgs/msg/PoseArray"),
    TopicSpec("/diagnostics", "diagnostic_msgs/msg/DiagnosticArray"),
)
"""Every documented topic of a simulated run (docs/interfaces.md, docs/phri_sim.md,
docs/wholebody_controller.md), as recorded by ``phri sim``. ``/diagnostics`` comes at ~1 Hz."""

TF_TOPIC = TopicSpec("/tf", "tf2_msgs/msg/TFMessage")
"""Link transforms the recorder adds (computed from /joint_states and /odom), so a recording
shows the robot in Foxglove / Lichtblick without a robot state publisher."""


def robot_description_urdf() -> str:
    """The robot's URDF (phri_description's one description), for robot_state_publisher/rviz."""
    from phri_description.urdf_writer import urdf_string

    return urdf_string()


def launch_node_kwargs(spec: NodeSpec, urdf: str = "") -> dict[str, Any]:
    """Keyword arguments of ``launch_ros.actions.Node`` for ``spec`` (what the launch files
    pass; pure so the tests can check it without launch_ros)."""
    kwargs: dict[str, Any] = {
        "package": spec.package,
        "executable": spec.executable,
        "name": spec.name,
        "output": "screen",
    }
    if spec.namespace:
        kwargs["namespace"] = spec.namespace
    if spec.package == "rviz2":
        kwargs["arguments"] = ["-d", str(share_dir() / str(spec.parameters["config"]))]
        return kwargs
    inline = dict(spec.parameters)
    if inline.get("robot_description") == "<URDF>":
        inline["robot_description"] = urdf
    kwargs["parameters"] = [str(config_file(f)) for f in spec.parameter_files] + (
        [inline] if inline else [])
    if spec.remappings:
        kwargs["remappings"] = list(spec.remappings)
    return kwargs
