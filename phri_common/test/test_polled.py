"""Polled subscriptions: messages wait in the reader queue, whatever the node's executor does,
until their owner takes them — all of them, in order, at most ``depth`` per call."""

from __future__ import annotations

import time

import pytest
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import QoSProfile
from rclpy.serialization import deserialize_message
from std_msgs.msg import Int32

from phri_common.polled import PolledSubscription

pytestmark = pytest.mark.ros


def wait_for_match(pub: object, sub: PolledSubscription, timeout: float = 10.0) -> None:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if pub.get_subscription_count() > 0 and sub.get_publisher_count() > 0:  # type: ignore[attr-defined]
            return
        time.sleep(0.01)
    raise AssertionError("publisher and polled subscription never matched")


def test_messages_wait_for_their_owner_not_the_executor(ros_context: Context) -> None:
    owner = Node("polled_owner", namespace="/ns", context=ros_context)
    peer = Node("polled_peer", context=ros_context)
    executor = SingleThreadedExecutor(context=ros_context)
    executor.add_node(owner)
    sub = PolledSubscription(owner, Int32, "counts", QoSProfile(depth=50))
    pub = peer.create_publisher(Int32, "/ns/counts", QoSProfile(depth=50))
    try:
        assert sub.topic_name == "/ns/counts"  # resolved in the node's namespace
        assert sub.take() is None
        wait_for_match(pub, sub)
        for k in range(20):
            pub.publish(Int32(data=k))
        end = time.monotonic() + 0.3
        while time.monotonic() < end:  # the executor spins the owner: it must not take them
            executor.spin_once(timeout_sec=0.01)
        values = [deserialize_message(data, Int32).data for data in sub.take_all()]
        assert values == list(range(20))
        assert list(sub.take_all()) == []
    finally:
        sub.destroy()
        executor.shutdown()
        peer.destroy_node()
        owner.destroy_node()


def test_the_reader_keeps_the_newest_depth_messages_for_the_owner(ros_context: Context) -> None:
    owner = Node("polled_depth_owner", context=ros_context)
    sub = PolledSubscription(owner, Int32, "depth_counts", QoSProfile(depth=5))
    pub = owner.create_publisher(Int32, "depth_counts", QoSProfile(depth=50))
    try:
        wait_for_match(pub, sub)
        for k in range(12):
            pub.publish(Int32(data=k))
        time.sleep(0.2)
        # KEEP_LAST 5: the reader holds the newest five; one call takes them, oldest first.
        values = [deserialize_message(data, Int32).data for data in sub.take_all()]
        assert values == [7, 8, 9, 10, 11]
    finally:
        sub.destroy()
        owner.destroy_node()
