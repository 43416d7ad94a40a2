"""phri on the real robot: skin drivers on their serial ports, contact estimation, the
whole-body controller, the phri_hardware UR arm bridges (namespaces left/right) and base guard,
robot_state_publisher, and optionally rviz.

    ros2 launch phri_bringup real.launch.py [hardware_config:=DIR]
        [skin_left_port:=PORT] [skin_right_port:=PORT] [layout_dir:=DIR]
        [skin_process:=composed|separate] [taxel_rate_hz:=50.0]
        [base_cmd_topic:=/base_driver/cmd_vel] [arm_driver:=phri_rtde|ur_robot_driver]
        [rviz:=true]

The nodes come from ``phri_bringup.graph.nodes.real_graph`` (the one description of the graph).
Parameters: phri_hardware's ``ur_arms.yaml``, ``base_guard.yaml`` and ``skin_real.yaml`` (from
its share directory, or from ``hardware_config:=DIR`` holding your edited copies), then
``config/real.yaml`` (docs/bringup.md). The skin ports and layouts come from ``skin_real.yaml``
unless given here; ``layout_dir`` holds ``<patch>.yaml`` (``phri layouts DIR`` writes nominal
ones). The base guard's ``base/cmd_vel`` is remapped to ``base_cmd_topic``.
``skin_process``: ``composed`` (default) runs both skin drivers and the contact estimation in one
``skin_contact_node`` process (frames handed over directly, each taxel topic published at
``taxel_rate_hz``), ``separate`` one process per node.
``arm_driver``: ``phri_rtde`` (default) starts phri_hardware's UR arm bridge per arm;
``ur_robot_driver`` starts none: Universal Robots' driver, running already (one per arm,
namespaces left/right, forward_velocity_controller active; docs/bringup_guide.md), takes the
same commands.

Nothing starts while a value is still marked PLACEHOLDER in those files, a layout file is
missing or an executable is not installed: the error names the file and line to edit.
"""

from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, OpaqueFunction
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node

from phri_bringup.graph.nodes import (
    ARM_DRIVERS,
    DEFAULT_ARM_DRIVER,
    DEFAULT_BASE_COMMAND_TOPIC,
    DEFAULT_SKIN_PROCESS,
    DEFAULT_TAXEL_RATE_HZ,
    SKIN_PROCESSES,
    launch_node_kwargs,
    real_graph,
    robot_description_urdf,
)
from phri_bringup.graph.preflight import ament_executable_exists, launch_problems, preflight_action


def _nodes(context):
    def arg(name):
        return LaunchConfiguration(name).perform(context)

    ports = {"skin_driver_left": arg("skin_left_port"),
             "skin_driver_right": arg("skin_right_port")}
    graph = real_graph(ports, arg("layout_dir"), arg("rviz").lower() in ("true", "1", "yes"),
                       arg("hardware_config"), arg("base_cmd_topic"), arg("skin_process"),
                       float(arg("taxel_rate_hz")), arg("arm_driver"))
    urdf = robot_description_urdf()
    check = preflight_action("real.launch.py",
                             lambda: launch_problems(graph, ament_executable_exists, real=True))
    return [check, *(Node(**launch_node_kwargs(spec, urdf)) for spec in graph)]


def generate_launch_description():
    return LaunchDescription([
        DeclareLaunchArgument("hardware_config", default_value="",
                              description="directory with edited copies of phri_hardware's "
                                          "ur_arms.yaml, base_guard.yaml, skin_real.yaml "
                                          "(default: phri_hardware's share/config)"),
        DeclareLaunchArgument("skin_left_port", default_value="",
                              description="serial port of the left arm's skin boards "
                                          "(default: skin_real.yaml)"),
        DeclareLaunchArgument("skin_right_port", default_value="",
                              description="serial port of the right arm's skin boards "
                                          "(default: skin_real.yaml)"),
        DeclareLaunchArgument("layout_dir", default_value="",
                              description="directory of <patch>.yaml skin layout files "
                                          "(default: skin_real.yaml's layout_files)"),
        DeclareLaunchArgument("skin_process", default_value=DEFAULT_SKIN_PROCESS,
                              choices=list(SKIN_PROCESSES),
                              description="composed: skin drivers and contact estimation in one "
                                          "process (direct hand-off); separate: one process "
                                          "per node"),
        DeclareLaunchArgument("taxel_rate_hz", default_value=str(DEFAULT_TAXEL_RATE_HZ),
                              description="composed only: rate of each skin/<patch>/taxels "
                                          "topic [Hz] (0 = every frame)"),
        DeclareLaunchArgument("base_cmd_topic", default_value=DEFAULT_BASE_COMMAND_TOPIC,
                              description="the base driver's twist input (base_guard output)"),
        DeclareLaunchArgument("arm_driver", default_value=DEFAULT_ARM_DRIVER,
                              choices=list(ARM_DRIVERS),
                              description="phri_rtde: phri_hardware's UR arm bridges (ur_rtde); "
                                          "ur_robot_driver: no bridge, Universal Robots' driver "
                                          "(started beforehand, one per arm in namespaces "
                                          "left/right, forward_velocity_controller active)"),
        DeclareLaunchArgument("rviz", default_value="false", description="start rviz2"),
        OpaqueFunction(function=_nodes),
    ])
