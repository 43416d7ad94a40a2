"""Subscriptions their owner reads (takes) itself, once per control cycle, outside any executor.

A control loop that uses only the latest inputs at each cycle gains nothing from being woken
for every message: with rclpy 9.1's events executor each message is an event (a C++ → Python
round trip and two thread wake-ups) of CPU outside the callback (docs/benchmarks.md,
"Controller node"). A
:class:`PolledSubscription` is an ordinary subscription of the node in rcl and DDS — same topic
name resolution and remapping, same QoS, listed by ``ros2 node info`` — that is not registered
with the node's executor: messages wait in the reader's queue (``qos.depth`` of them) until
:meth:`PolledSubscription.take_all` reads them, in arrival order.

rclpy offers no public way to create a subscription an executor will not service; this uses
rclpy's own binding (``rclpy.impl.implementation_singleton``), the constructor that
``Node.create_subscription`` calls, with the Kilted wheels pinned in requirements.txt. The
node's tests cover it (``wholebody_controller/test/test_node.py``, ``control_loop: thread``).
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy
from rclpy.node import Node
from rclpy.qos import QoSProfile
from rclpy.type_support import check_is_valid_msg_type


class PolledSubscription:
    """A subscription of ``node`` to ``topic`` whose serialized messages are taken on demand."""

    def __init__(self, node: Node, msg_type: Any, topic: str, qos: QoSProfile) -> None:
        check_is_valid_msg_type(msg_type)  # loads the type support the constructor needs
        self.msg_type = msg_type
        self.depth = max(int(qos.depth), 1)
        with node.handle:
            self._handle = _rclpy.Subscription(node.handle, msg_type, topic,
                                               qos.get_c_qos_profile())
        self.topic_name: str = self._handle.get_topic_name()
        """The fully resolved topic name (after namespace and remapping)."""

    def take(self) -> bytes | None:
        """The oldest queued message, serialized, or None when the queue is empty."""
        with self._handle:
            taken = self._handle.take_message(self.msg_type, True)
        return None if taken is None else bytes(taken[0])

    def take_all(self) -> Iterator[bytes]:
        """Every message queued now, oldest first (at most ``depth``: a publisher faster than the
        reader cannot keep it here forever)."""
        for _ in range(self.depth):
            data = self.take()
            if data is None:
                return
            yield data

    def get_publisher_count(self) -> int:
        """Publishers matched on the topic."""
        with self._handle:
            return int(self._handle.get_publisher_count())

    def destroy(self) -> None:
        """Remove the subscription (before its node is destroyed)."""
        self._handle.destroy_when_not_in_use()
