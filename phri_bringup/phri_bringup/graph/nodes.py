"""THE description of phri's node graph (pure Python: no rclpy, no launch).

``sim.launch.py``, ``real.launch.py`` and the in-process runner behind ``phri sim`` are all built
from the lists below, so the nodes, executables, namespaces, parameter files and remappings
cannot drift apart (``test_graph.py`` checks the launch files against this module and the
running in-process nodes against the parameter files).

A :class:`NodeSpec` names a node the way ``launch_ros.actions.Node`` wants it (package,
executable, name, namespace, parameter files, inline parameters, remappings); ``in_process``
marks the nodes that the lock-step runner also creates in one process (the robot state publisher
and rviz exist only on a ROS install). A spec with ``nodes`` is one process holding several
nodes (the real robot's composed skin drivers + contact estimation, ``skin_contact_node``):
:func:`ros_nodes` lists the nodes of a graph, the graph's own list its processes.

It also lists the documented topics with their types (:data:`SIM_TOPICS`), which the recorder
subscribes and the tests expect in a recording.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from phri_common.share import package_share
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
    "waltz_tempo": "waltz_tempo",
    "waltz_paper": "waltz_paper",
}
"""Command-line scenario names → phri_sim scenario names."""

SCENARIO_FILES: dict[str, str] = {
    "centring": "centring",
    "sliding": "sliding",
    "whole_body": "wholebody",
    "waltz": "waltz",
    "waltz_tempo": "waltz_tempo",
    "waltz_paper": "waltz_paper",
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
"""Values the lock-step runner sets instead of the parameter file's (phri_sim.ros.runner: one skin
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
            file passes the files; the runner loads the same sections), or another package's
            file as ``package/path.yaml``, or an absolute path (see :func:`config_file`).
        parameters: inline parameters (launch arguments resolved by the caller).
        remappings: (from, to) topic pairs.
        in_process: the lock-step runner also creates this node in one process.
        description: one line for listings and the docs.
        nodes: for a process that holds several nodes: one spec per node (its ``name``,
            ``parameter_files`` and ``parameters``; ``package``/``executable`` name the node's
            own class); the process spec's ``name`` is then only a label and its
            ``parameter_files``/``parameters`` are unused.
        arguments: command-line arguments before ``--ros-args``.
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
    nodes: tuple[NodeSpec, ...] = ()
    arguments: tuple[str, ...] = ()


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


def share_dir(package: str = PACKAGE) -> Path:
    """Directory holding a package's data files (``config/``; for phri_bringup also
    ``launch/``, ``rviz/``): :func:`phri_common.share.package_share` (the ament index's share
    directory, else the source tree)."""
    return package_share(package)


def config_file(stem: str) -> Path:
    """Path of ``config/<stem>.yaml`` (phri_bringup), or of ``<package>/<path>`` in another
    package's share directory when ``stem`` has the form ``package/relative/path.yaml``."""
    if Path(stem).is_absolute():
        return Path(stem)
    if "/" in stem:
        package, _, relative = stem.partition("/")
        return share_dir(package) / relative
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
        nodes.append(rviz_node(sim_time=True))
    return nodes


def rviz_node(sim_time: bool = False) -> NodeSpec:
    """rviz2 with ``rviz/phri.rviz`` (on the simulation's clock when ``sim_time``)."""
    return NodeSpec("rviz2", "rviz2", "rviz2",
                    parameters={"config": "rviz/phri.rviz", "use_sim_time": sim_time},
                    description="robot, taxel clouds and contacts")


REAL_SKIN_PORTS: dict[str, tuple[str, ...]] = {
    f"skin_driver_{side}": tuple(p for p in SKIN_PATCHES if p.startswith(f"{side}_"))
    for side in SIDES
}
"""Real skin wiring: driver node → patches on its serial port, in board-id order."""

HARDWARE_CONFIG: dict[str, str] = {
    "skin_driver": "skin_real.yaml",
    "ur_arm_bridge": "ur_arms.yaml",
    "base_guard": "base_guard.yaml",
}
"""phri_hardware parameter file of each real-robot executable family (docs/hardware.md): the
site-specific values (ports, layouts, robot addresses, the base driver's message type)."""

BASE_GUARD_OUTPUT = "base/cmd_vel"
"""base_guard_node's output topic, remapped to the base driver's twist input."""
DEFAULT_BASE_COMMAND_TOPIC = "/base_driver/cmd_vel"
"""Default of real.launch.py's ``base_cmd_topic``: where the limited base twist goes."""


def hardware_config(name: str, directory: str = "") -> str:
    """Parameter file entry of a phri_hardware config file: ``directory/name`` when a directory
    with edited copies is given, else the file in phri_hardware's share (see config_file)."""
    return str(Path(directory).resolve() / name) if directory else f"phri_hardware/config/{name}"


SKIN_PROCESSES: tuple[str, ...] = ("composed", "separate")
"""How the real robot runs its skin drivers and contact estimation: ``composed`` = one
``skin_contact_node`` process (drivers hand frames to the estimator directly, taxel topics at
``taxel_rate_hz``), ``separate`` = one process per driver and one for the estimator (every frame
crosses DDS). ``bench/bench_chain.py`` measures both (docs/benchmarks.md, "End to end")."""
DEFAULT_SKIN_PROCESS = "composed"
"""real.launch.py's ``skin_process`` default: the composed process dropped fewer frames with
less CPU and lower latency in every ``bench_chain.py`` series (docs/benchmarks.md, "End to end")."""
DEFAULT_TAXEL_RATE_HZ = 50.0
"""real.launch.py's ``taxel_rate_hz`` default [Hz]: each patch's taxel topic in the composed
process (rviz, recording, diagnostics tools; the estimator gets every frame directly)."""
SKIN_CONTACT = "skin_contact"
"""Label of the composed process (``phri_bringup/skin_contact_node``); not a node name."""


def _skin_driver_specs(ports: dict[str, str], layout_dir: str, skin_file: str,
                       extra: dict[str, Any]) -> list[NodeSpec]:
    """One skin_driver node per real port: ``skin_file`` then ``config/real.yaml``, then the
    port, the layouts of ``layout_dir`` (made absolute) and ``extra`` when given."""
    specs = []
    for name, patches in REAL_SKIN_PORTS.items():
        overrides: dict[str, Any] = dict(extra)
        if ports.get(name):
            overrides["port"] = ports[name]
        if layout_dir:
            root = Path(layout_dir).resolve()
            overrides["layout_files"] = [str(root / f"{p}.yaml") for p in patches]
        specs.append(NodeSpec(
            name, "skin_driver", "skin_driver_node", parameter_files=(skin_file, "real"),
            parameters=overrides, description=f"skin boards of {', '.join(patches)}",
        ))
    return specs


def real_skin_processes(ports: dict[str, str] | None = None, layout_dir: str = "",
                        hardware_dir: str = "", skin_process: str = DEFAULT_SKIN_PROCESS,
                        taxel_rate_hz: float = DEFAULT_TAXEL_RATE_HZ) -> list[NodeSpec]:
    """The skin drivers and contact estimation of the real robot, as ``skin_process`` says
    (:data:`SKIN_PROCESSES`): one composed process, or one process per node.

    Raises:
        ValueError: unknown ``skin_process``, or ``taxel_rate_hz`` < 0 (names the value).
    """
    if skin_process not in SKIN_PROCESSES:
        raise ValueError(f"skin_process refused {skin_process!r}: allowed "
                         f"{', '.join(SKIN_PROCESSES)}")
    if not taxel_rate_hz >= 0.0:
        raise ValueError(f"taxel_rate_hz refused {taxel_rate_hz!r}: allowed ≥ 0 Hz "
                         "(0 = every frame)")
    skin_file = hardware_config(HARDWARE_CONFIG["skin_driver"], hardware_dir)
    composed = skin_process == "composed"
    drivers = _skin_driver_specs(
        ports or {}, layout_dir, skin_file,
        {"taxel_publish_rate_hz": float(taxel_rate_hz)} if composed else {})
    estimation = NodeSpec(ESTIMATION, "contact_estimation", "contact_estimation_node",
                          parameter_files=("real",), description="contact state per link")
    if not composed:
        return [*drivers, estimation]
    return [NodeSpec(
        SKIN_CONTACT, PACKAGE, "skin_contact_node", nodes=(*drivers, estimation),
        arguments=("--drivers", *(d.name for d in drivers)),
        description=f"{len(drivers)} skin drivers + contact estimation in one process "
                    f"(direct hand-off; taxel topics at {taxel_rate_hz:g} Hz)",
    )]


def ros_nodes(graph: list[NodeSpec]) -> list[NodeSpec]:
    """The ROS nodes of a graph: a multi-node process's ``nodes`` in place of the process."""
    return [n for spec in graph for n in (spec.nodes or (spec,))]


ARM_DRIVERS: tuple[str, ...] = ("phri_rtde", "ur_robot_driver")
"""What drives the UR arms on the real robot (real.launch.py's ``arm_driver``): ``phri_rtde`` =
phri_hardware's ``ur_arm_bridge_node`` per arm (ur_rtde, started by the launch file);
``ur_robot_driver`` = Universal Robots' ROS 2 driver, started by the user beforehand, one per arm
in namespace ``left``/``right`` with tf_prefix ``left_``/``right_`` and its
``forward_velocity_controller`` active (docs/bringup_guide.md): the launch file then starts no
arm bridge. Both take ``<arm>/forward_velocity_controller/commands`` and publish the joint states
and ``<arm>/speed_scaling_state_broadcaster/speed_scaling``."""
DEFAULT_ARM_DRIVER = "phri_rtde"


def real_graph(ports: dict[str, str] | None = None, layout_dir: str = "",
               rviz: bool = False, hardware_dir: str = "",
               base_cmd_topic: str = DEFAULT_BASE_COMMAND_TOPIC,
               skin_process: str = DEFAULT_SKIN_PROCESS,
               taxel_rate_hz: float = DEFAULT_TAXEL_RATE_HZ,
               arm_driver: str = DEFAULT_ARM_DRIVER) -> list[NodeSpec]:
    """Processes on the real robot: skin drivers and estimation (:func:`real_skin_processes`:
    composed or separate), controller, the phri_hardware arm bridges (namespaces
    ``left``/``right``; none with ``arm_driver`` ``ur_robot_driver``, :data:`ARM_DRIVERS`) and
    base guard, and the robot state publisher.

    Parameters come from phri_hardware's files (``hardware_dir`` replaces its share directory),
    then ``config/real.yaml``; ``ports`` (driver node → port) and ``layout_dir`` (``<patch>.yaml``
    files, made absolute) override the skin file's values when given; the base guard's output is
    remapped to ``base_cmd_topic``.

    Raises:
        ValueError: unknown ``arm_driver`` or ``skin_process``, or ``taxel_rate_hz`` < 0.
    """
    if arm_driver not in ARM_DRIVERS:
        raise ValueError(f"arm_driver refused {arm_driver!r}: allowed {', '.join(ARM_DRIVERS)}")
    bridges = ARMS if arm_driver == "phri_rtde" else ()
    nodes = real_skin_processes(ports, layout_dir, hardware_dir, skin_process, taxel_rate_hz)
    nodes += [
        NodeSpec(CONTROLLER, "wholebody_controller", "wholebody_controller_node",
                 parameter_files=("real",), description="whole-body admittance QP"),
        *(NodeSpec("ur_arm_bridge", "phri_hardware", "ur_arm_bridge_node", namespace=arm,
                   parameter_files=(hardware_config(HARDWARE_CONFIG["ur_arm_bridge"],
                                                    hardware_dir),),
                   description=f"{arm} UR16e: forward_velocity_controller/commands → RTDE "
                               "speedJ, joint states, speed scaling")
          for arm in bridges),
        NodeSpec("base_guard", "phri_hardware", "base_guard_node",
                 parameter_files=(hardware_config(HARDWARE_CONFIG["base_guard"], hardware_dir),),
                 remappings=((BASE_GUARD_OUTPUT, base_cmd_topic),),
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
"""Transforms of the moving joints, which the recorder adds (computed from /joint_states and
/odom), so a recording shows the robot in Foxglove / Lichtblick without a robot state publisher."""
TF_STATIC_TOPIC = TopicSpec("/tf_static", "tf2_msgs/msg/TFMessage")
"""Transforms of the fixed joints, recorded once at the start, latched (transient local), as
robot_state_publisher publishes them."""


ROBOT_DESCRIPTION_TOPIC = TopicSpec("/robot_description", "std_msgs/msg/String")
"""The URDF, latched (transient local). robot_state_publisher publishes it on a ROS install; in
``phri sim`` (no robot_state_publisher) the observer node does, so rviz and Foxglove find it; the
recorder writes it once at the start with its latched QoS, so ``ros2 bag play`` replays it
latched."""

RECORDED_EXTRA_TOPICS: tuple[TopicSpec, ...] = (TF_TOPIC, TF_STATIC_TOPIC,
                                                ROBOT_DESCRIPTION_TOPIC)
"""What a recording holds beside :data:`SIM_TOPICS` (the recorder computes or knows them)."""


def robot_description_urdf() -> str:
    """The robot's URDF (phri_description's one description), for robot_state_publisher/rviz."""
    from phri_description.urdf_writer import urdf_string

    return urdf_string()


def launch_node_kwargs(spec: NodeSpec, urdf: str = "") -> dict[str, Any]:
    """Keyword arguments of ``launch_ros.actions.Node`` for ``spec`` (what the launch files
    pass; pure so the tests can check it without launch_ros)."""
    if spec.nodes:
        return _process_kwargs(spec)
    kwargs: dict[str, Any] = {
        "package": spec.package,
        "executable": spec.executable,
        "name": spec.name,
        "output": "screen",
    }
    if spec.namespace:
        kwargs["namespace"] = spec.namespace
    inline = dict(spec.parameters)
    if spec.package == "rviz2":
        kwargs["arguments"] = ["-d", str(share_dir() / str(inline.pop("config")))]
    if inline.get("robot_description") == "<URDF>":
        inline["robot_description"] = urdf
    kwargs["parameters"] = [str(config_file(f)) for f in spec.parameter_files] + (
        [inline] if inline else [])
    if spec.remappings:
        kwargs["remappings"] = list(spec.remappings)
    return kwargs


def _process_kwargs(spec: NodeSpec) -> dict[str, Any]:
    """``launch_ros.actions.Node`` keyword arguments of a multi-node process: no ``name`` (a
    ``__node`` remap would rename every node in it), every node's parameter files once (each
    file's ``<node>:`` sections reach their node by name), and inline parameters scoped to their
    node as ``-p <node>:<name>:=<value>`` (values in JSON, which the ROS argument parser reads
    as YAML)."""
    import json

    files = list(dict.fromkeys(str(config_file(f)) for n in spec.nodes
                               for f in n.parameter_files))
    kwargs: dict[str, Any] = {
        "package": spec.package,
        "executable": spec.executable,
        "output": "screen",
        "arguments": list(spec.arguments),
        "parameters": files,
    }
    scoped = [arg for n in spec.nodes for key, value in n.parameters.items()
              for arg in ("-p", f"{n.name}:{key}:={json.dumps(value)}")]
    if scoped:
        kwargs["ros_arguments"] = scoped
    return kwargs
