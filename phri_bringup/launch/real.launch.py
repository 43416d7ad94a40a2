"""phri on the real robot: skin drivers on their serial ports, contact estimation, the
whole-body controller, the phri_hardware UR arm bridges (namespaces left/right) and base guard,
robot_state_publisher, and optionally rviz.

    ros2 launch phri_bringup real.launch.py [skin_left_port:=/dev/ttyACM0]
        [skin_right_port:=/dev/ttyACM1] [layout_dir:=/path/to/layouts] [rviz:=true]

The nodes come from ``phri_bringup.graph.real_graph`` (the one description of the graph);
parameters from ``config/real.yaml`` (docs/bringup.md). Layout files: ``phri layouts DIR``
writes nominal ones; replace them with the calibrated files of your skin.
"""

from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, OpaqueFunction
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node

from phri_bringup.graph import launch_node_kwargs, real_graph, robot_description_urdf


def _nodes(context):
    ports = {
        "skin_driver_left": LaunchConfiguration("skin_left_port").perform(context),
        "skin_driver_right": LaunchConfiguration("skin_right_port").perform(context),
    }
    layout_dir = LaunchConfiguration("layout_dir").perform(context)
    rviz = LaunchConfiguration("rviz").perform(context).lower() in ("true", "1", "yes")
    urdf = robot_description_urdf()
    return [Node(**launch_node_kwargs(spec, urdf))
            for spec in real_graph(ports, layout_dir, rviz)]


def generate_launch_description():
    return LaunchDescription([
        DeclareLaunchArgument("skin_left_port", default_value="/dev/ttyACM0",
                              description="serial port of the left arm's skin boards"),
        DeclareLaunchArgument("skin_right_port", default_value="/dev/ttyACM1",
                              description="serial port of the right arm's skin boards"),
        DeclareLaunchArgument("layout_dir", default_value="config/skin",
                              description="directory of <patch>.yaml skin layout files"),
        DeclareLaunchArgument("rviz", default_value="false", description="start rviz2"),
        OpaqueFunction(function=_nodes),
    ])
