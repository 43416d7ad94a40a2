"""Simulated phri: the MuJoCo robot, skins and person, contact estimation, the whole-body
controller, robot_state_publisher, and optionally rviz (on the simulation's clock).

    ros2 launch phri_bringup sim.launch.py scenario:=waltz [seed:=0] [rviz:=true]

The nodes, executables and parameter files come from ``phri_bringup.graph.nodes.sim_graph`` — the
same description ``phri sim`` runs in one process — so the two cannot drift. Parameters:
``config/<scenario>.yaml`` (docs/bringup.md). Every executable is looked up before any process
starts: a missing package (e.g. robot_state_publisher) stops the launch with nothing running.
"""

from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, OpaqueFunction
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node

from phri_bringup.graph.nodes import launch_node_kwargs, robot_description_urdf, sim_graph
from phri_bringup.graph.preflight import ament_executable_exists, launch_problems, preflight_action


def _nodes(context):
    scenario = LaunchConfiguration("scenario").perform(context)
    seed = int(LaunchConfiguration("seed").perform(context))
    rviz = LaunchConfiguration("rviz").perform(context).lower() in ("true", "1", "yes")
    graph = sim_graph(scenario, seed, rviz)
    urdf = robot_description_urdf()
    check = preflight_action("sim.launch.py",
                             lambda: launch_problems(graph, ament_executable_exists))
    return [check, *(Node(**launch_node_kwargs(spec, urdf)) for spec in graph)]


def generate_launch_description():
    return LaunchDescription([
        DeclareLaunchArgument("scenario", default_value="waltz",
                              description="centring, sliding, wholebody, waltz, waltz_tempo "
                                          "or waltz_paper"),
        DeclareLaunchArgument("seed", default_value="0", description="skin noise seed"),
        DeclareLaunchArgument("rviz", default_value="false", description="start rviz2"),
        OpaqueFunction(function=_nodes),
    ])
