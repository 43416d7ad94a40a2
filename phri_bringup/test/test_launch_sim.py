"""launch_testing: sim.launch.py on a ROS install (skipped where launch_testing is absent).

Checks: the graph's topics are alive, the robot moves when the scenario pushes it, a real skin
frame with NaN forces and a NaN taxel position keeps every node active and every command finite,
and every process exits cleanly. The same checks run in CI
through the in-process runner (test_session.py, test_cli.py).
"""

from __future__ import annotations

import math
import os
import time
import unittest

import pytest

pytest.importorskip("launch_testing")
pytest.importorskip("launch_ros")

import launch
import launch_testing.actions
import launch_testing.asserts
import numpy as np
import rclpy
from launch.actions import IncludeLaunchDescription
from launch.launch_description_sources import PythonLaunchDescriptionSource
from sensor_msgs.msg import JointState, PointCloud2
from std_msgs.msg import Float64MultiArray

from phri_bringup.graph.nodes import SIM_TOPICS, share_dir
from phri_common.taxels import TaxelArray, msg_to_taxels, taxels_to_msg

pytestmark = pytest.mark.launch_test


@pytest.mark.launch_test
def generate_test_description():  # type: ignore[no-untyped-def]
    sim = IncludeLaunchDescription(
        PythonLaunchDescriptionSource(os.path.join(share_dir(), "launch", "sim.launch.py")),
        launch_arguments={"scenario": "centring"}.items(),
    )
    return launch.LaunchDescription([sim, launch_testing.actions.ReadyToTest()])


class TestSimBringup(unittest.TestCase):
    @classmethod
    def setUpClass(cls) -> None:
        rclpy.init()
        cls.node = rclpy.create_node("phri_launch_test")

    @classmethod
    def tearDownClass(cls) -> None:
        cls.node.destroy_node()
        rclpy.shutdown()

    def _wait(self, condition, timeout: float = 30.0) -> bool:  # type: ignore[no-untyped-def]
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            rclpy.spin_once(self.node, timeout_sec=0.1)
            if condition():
                return True
        return False

    def test_topics_alive(self) -> None:
        names = {name for name, _ in self.node.get_topic_names_and_types()}
        expected = {t.name for t in SIM_TOPICS if t.name != "/diagnostics"}
        self.assertTrue(self._wait(lambda: expected <= {
            n for n, _ in self.node.get_topic_names_and_types()}), expected - names)

    def test_robot_moves_when_pushed_and_survives_nan(self) -> None:
        speeds: list[float] = []
        commands: list[list[float]] = []
        taxels: list[PointCloud2] = []
        self.node.create_subscription(
            JointState, "/joint_states",
            lambda m: speeds.append(max((abs(v) for v in m.velocity), default=0.0)), 10)
        self.node.create_subscription(
            Float64MultiArray, "/right/forward_velocity_controller/commands",
            lambda m: commands.append(list(m.data)), 10)
        self.node.create_subscription(PointCloud2, "/skin/right_forearm/taxels",
                                      taxels.append, 10)
        # The centring scenario presses the right forearm from 1 s (sim time) on.
        self.assertTrue(self._wait(lambda: any(s > 1e-3 for s in speeds), 60.0))
        self.assertTrue(taxels)
        # A real skin frame of the pressed patch with NaN forces and a NaN taxel position.
        frame = msg_to_taxels(taxels[-1])
        forces = np.full_like(frame.forces, np.nan)
        positions = frame.positions.copy()
        positions[0] = np.nan
        bad = taxels_to_msg(TaxelArray(positions, frame.normals, forces, frame.weights,
                                       frame.frame_id, frame.stamp_ns))
        self.assertEqual(bad.width, taxels[-1].width)
        pub = self.node.create_publisher(PointCloud2, "/skin/right_forearm/taxels", 10)
        for _ in range(20):
            pub.publish(bad)
            rclpy.spin_once(self.node, timeout_sec=0.01)
        count, sent = len(speeds), len(commands)
        self.assertTrue(self._wait(lambda: len(speeds) > count + 50, 20.0))
        self.assertTrue(self._wait(lambda: len(commands) > sent + 20, 20.0))
        self.assertTrue(all(math.isfinite(s) for s in speeds))
        self.assertTrue(all(math.isfinite(v) for c in commands for v in c))
        nodes = set(self.node.get_node_names())
        self.assertTrue({"phri_sim", "contact_estimation", "wholebody_controller"} <= nodes)


@launch_testing.post_shutdown_test()
class TestCleanExit(unittest.TestCase):
    def test_exit_codes(self, proc_info) -> None:  # type: ignore[no-untyped-def]
        launch_testing.asserts.assertExitCodes(
            proc_info, allowable_exit_codes=[0, -2, -15, 130])
