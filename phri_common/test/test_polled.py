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


def wait_for_match(pub: object, sub: PolledSubscription, timeout: float = 60.0) -> None:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if pub.get_subscription_count() > 0 and sub.get_publisher_count() > 0:  # type: ignore[attr-defined]
            return
        time.sleep(0.01)
    raise AssertionError("publisher and polled subscription never matched")


def spin_until_received(executor: SingleThreadedExecutor, received: list[int], count: int,
                        timeout: float = 60.0) -> None:
    """Spin ``executor`` until an ordinary subscription has ``count`` messages (the wait only
    bounds a stalled machine)."""
    deadline = time.monotonic() + timeout
    while len(received) < count and time.monotonic() < deadline:
        executor.spin_once(timeout_sec=0.01)
    assert len(received) == count, f"{len(received)} of {count} messages arrived"


def test_messages_wait_for_their_owner_not_the_executor(ros_context: Context) -> None:
    owner = Node("polled_owner", namespace="/ns", context=ros_context)
    peer = Node("polled_peer", context=ros_context)
    executor = SingleThreadedExecutor(context=ros_context)
    executor.add_node(owner)
    sub = PolledSubscription(owner, Int32, "counts", QoSProfile(depth=50))
    # An ordinary subscription of the same node on the same topic: the executor delivers to
    # it, so once it has every message the executor has spun the owner over all of them.
    seen: list[int] = []
    owner.create_subscription(Int32, "counts", lambda m: seen.append(m.data), QoSProfile(depth=50))
    pub = peer.create_publisher(Int32, "/ns/counts", QoSProfile(depth=50))
    try:
        assert sub.topic_name == "/ns/counts"  # resolved in the node's namespace
        assert sub.take() is None
        wait_for_match(pub, sub)
        for k in range(20):
            pub.publish(Int32(data=k))
        spin_until_received(executor, seen, 20)  # the executor spun the owner: it took none
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
    witness = Node("polled_depth_witness", context=ros_context)
    executor = SingleThreadedExecutor(context=ros_context)
    executor.add_node(witness)  # not the owner: its polled reader is only read by take_all
    sub = PolledSubscription(owner, Int32, "depth_counts", QoSProfile(depth=5))
    seen: list[int] = []
    witness.create_subscription(Int32, "depth_counts", lambda m: seen.append(m.data),
                                QoSProfile(depth=50))
    pub = owner.create_publisher(Int32, "depth_counts", QoSProfile(depth=50))
    try:
        wait_for_match(pub, sub)
        deadline = time.monotonic() + 60.0
        while pub.get_subscription_count() < 2 and time.monotonic() < deadline:
            time.sleep(0.01)
        for k in range(12):
            pub.publish(Int32(data=k))
        # Every message has reached this process's readers once the witness has all twelve.
        spin_until_received(executor, seen, 12)
        # KEEP_LAST 5: the reader holds the newest five; one call takes them, oldest first.
        values = [deserialize_message(data, Int32).data for data in sub.take_all()]
        assert values == [7, 8, 9, 10, 11]
    finally:
        sub.destroy()
        executor.shutdown()
        witness.destroy_node()
        owner.destroy_node()
