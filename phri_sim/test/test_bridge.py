"""Bridge node contracts: idle-skin decimation, physics-step validation, ground truth on demand."""

from __future__ import annotations

from typing import Any

import pytest
from geometry_msgs.msg import WrenchStamped
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from sensor_msgs.msg import PointCloud2

from phri_common.taxels import msg_to_taxels
from phri_common.testing import spin_until
from phri_sim.bridge import SimBridgeNode


def _bridge(ros_context: Any, **params: Any) -> SimBridgeNode:
    overrides = [Parameter("lockstep", value=True), Parameter("scenario", value="waltz"),
                 Parameter("skin_rate_hz", value=100.0)]
    overrides += [Parameter(k, value=v) for k, v in params.items()]
    return SimBridgeNode(context=ros_context, parameter_overrides=overrides)


@pytest.mark.ros
def test_idle_patches_are_decimated_touched_ones_are_not(ros_context: Any) -> None:
    """In the waltz only the left forearm is touched: it goes out every period, the two idle
    patches every 5th (and in the first period, for subscribers that joined late)."""
    node = _bridge(ros_context, skin_idle_decimation=5, physics_timestep=0.005)
    try:
        counts = dict.fromkeys(node.sim.patches, 0)
        for _ in range(12):
            node.advance(1, clock=False)
            for patch in node.published_patches:
                counts[patch] += 1
        assert counts["left_forearm"] == 12
        assert counts["left_upper_arm"] == 3
        assert counts["right_forearm"] == 3
    finally:
        node.destroy_node()


@pytest.mark.ros
def test_refuses_a_step_that_does_not_divide_the_period(ros_context: Any) -> None:
    with pytest.raises(ValueError, match="control_period"):
        _bridge(ros_context, physics_timestep=0.003)


@pytest.mark.ros
def test_ground_truth_and_skin_reach_a_subscriber(ros_context: Any) -> None:
    """Ground truth is published when someone listens: the waist's true force on the forearm
    (≈ the 10 N preload) and the forearm's taxels, whose total equals it within 2 %."""
    node = _bridge(ros_context, skin_noise_std=0.0)
    probe = Node("probe", context=ros_context)
    wrenches: list[WrenchStamped] = []
    skins: list[PointCloud2] = []
    probe.create_subscription(WrenchStamped, "sim/contacts/left_forearm_link/wrench",
                              wrenches.append, 10)
    probe.create_subscription(PointCloud2, "skin/left_forearm/taxels", skins.append, 10)
    executor = SingleThreadedExecutor(context=ros_context)
    executor.add_node(node)
    executor.add_node(probe)
    try:
        assert spin_until(executor, lambda: node.count_subscribers(
            "sim/contacts/left_forearm_link/wrench") > 0, timeout_s=10.0)
        node.advance(1)
        assert spin_until(executor, lambda: bool(wrenches) and bool(skins), timeout_s=10.0)
        f = wrenches[-1].wrench.force
        magnitude = (f.x**2 + f.y**2 + f.z**2) ** 0.5
        assert magnitude == pytest.approx(10.0, rel=0.15)
        total = float(msg_to_taxels(skins[-1]).forces.sum())
        normal = node.sim.ground_truth()["left_forearm_link"].normal_force
        assert total == pytest.approx(normal, rel=0.02)
    finally:
        executor.shutdown()
        probe.destroy_node()
        node.destroy_node()
