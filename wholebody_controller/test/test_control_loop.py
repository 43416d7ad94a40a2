"""``control_loop``: the controller's cycle in its own thread (inputs taken at each cycle) or on
an executor timer; the thread refused under simulation time; a thread that fails stops the robot
and the process."""

from __future__ import annotations

import time
from collections.abc import Callable

import numpy as np
import pytest
from diagnostic_msgs.msg import DiagnosticStatus
from numpy.typing import NDArray
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import QoSProfile
from sensor_msgs.msg import PointCloud2
from wbc_fake_kinematics import FakeKinematics

from phri_common.contact import contact_to_msg
from phri_common.contact_cdr import contact_from_cdr
from phri_common.records import ContactState
from wholebody_controller.messages import loop_status
from wholebody_controller.node import WholeBodyControllerNode
from wholebody_controller.parameters import control_loop_mode
from wholebody_controller.qos import CONTACT_QOS


@pytest.mark.parametrize(("value", "sim_time", "mode"), [
    ("auto", False, "thread"), ("auto", True, "timer"), ("thread", False, "thread"),
    ("timer", False, "timer"), ("timer", True, "timer"),
])
def test_control_loop_resolves_auto_by_the_clock(value: str, sim_time: bool, mode: str) -> None:
    assert control_loop_mode(value, sim_time) == mode


def test_control_loop_refusals_name_the_parameter_and_the_allowed_values() -> None:
    with pytest.raises(ValueError, match=r"'control_loop' refused value 'fast'.*auto, thread, "
                                         r"timer"):
        control_loop_mode("fast", False)
    with pytest.raises(ValueError, match="'control_loop' refused value 'thread' with "
                                         "use_sim_time"):
        control_loop_mode("thread", True)


WAIT_S = 60.0
"""Longest wait for something that must happen (a stalled machine); never a measured time."""


def wait(condition: Callable[[], bool], timeout: float = WAIT_S) -> bool:
    deadline = time.monotonic() + timeout
    while not condition() and time.monotonic() < deadline:
        time.sleep(0.005)
    return condition()


@pytest.mark.ros
def test_thread_under_simulation_time_is_refused_at_start(ros_context: object) -> None:
    with pytest.raises(ValueError, match="control_loop"):
        WholeBodyControllerNode(kinematics=FakeKinematics(), context=ros_context,
                                parameter_overrides=[Parameter("use_sim_time", value=True),
                                                     Parameter("control_loop", value="thread")])


class BreakingNode(WholeBodyControllerNode):
    """The node on its control thread; its 5th cycle raises an unexpected error."""

    def __init__(self, context: object) -> None:
        self.commands: list[NDArray[np.float64]] = []
        self.ticks = 0
        super().__init__(kinematics=FakeKinematics(), context=context,
                         parameter_overrides=[Parameter("control_loop", value="thread"),
                                              Parameter("rate_hz", value=200.0)])

    def publish_command(self, command: NDArray[np.float64]) -> None:
        self.commands.append(np.array(command))
        super().publish_command(command)

    def tick(self) -> None:
        self.ticks += 1
        if self.ticks == 5:
            raise KeyError("a bug")
        super().tick()
        self.commands[-1] = np.ones(15)  # pretend each good cycle commanded motion


@pytest.mark.ros
def test_a_failing_control_thread_commands_zero_reports_error_and_stops(
        ros_context: object) -> None:
    node = BreakingNode(ros_context)
    try:
        assert node.loop is not None
        assert wait(lambda: node.fatal_error is not None)
        assert wait(lambda: not node.loop.running)  # type: ignore[union-attr]
        assert isinstance(node.fatal_error, KeyError) and node.ticks == 5
        # The last command is zero (the good ones before were "moving").
        assert np.all(node.commands[-1] == 0.0) and np.all(node.commands[-2] == 1.0)
        status = loop_status(node.get_name(), node.control_loop, node.loop, node.fatal_error)
        assert status.level == DiagnosticStatus.ERROR and "a bug" in status.message
    finally:
        node.destroy_node()


@pytest.mark.ros
def test_the_thread_takes_every_queued_contact_state_in_order(ros_context: object) -> None:
    controller = WholeBodyControllerNode(
        kinematics=FakeKinematics(), context=ros_context,
        parameter_overrides=[Parameter("control_loop", value="thread")])
    peer = Node("control_loop_peer", context=ros_context)  # type: ignore[arg-type]
    link = "left_forearm_link"
    pub = peer.create_publisher(PointCloud2, f"contacts/{link}", QoSProfile(depth=50))
    # A witness in the same process: once it has all 20, they have reached the controller's
    # reader too (then the burst is queued, whatever the machine's load).
    witnessed: list[PointCloud2] = []
    peer.create_subscription(PointCloud2, f"contacts/{link}", witnessed.append,
                             QoSProfile(depth=50, reliability=CONTACT_QOS.reliability))
    witness = SingleThreadedExecutor(context=ros_context)  # type: ignore[arg-type]
    witness.add_node(peer)
    taken: list[tuple[int, int]] = []  # (stamp [ns], cycles run before the one that took it)
    with controller.cycle_lock:  # hold the cycle off while the burst is queued
        controller.on_contact_bytes = (  # type: ignore[method-assign]
            lambda lk, data: taken.append((contact_from_cdr(data).stamp_ns,  # type: ignore[union-attr]
                                           controller.loop.cycles)))  # type: ignore[union-attr]
        try:
            assert wait(lambda: pub.get_subscription_count() > 1), "no discovery"
            for k in range(20):
                state = ContactState(link, 1_000_000_000 + k, True, np.zeros(3),
                                     np.array([0.0, 0.0, 5.0]), np.zeros(3), -np.ones(3),
                                     np.ones(3), 16)
                pub.publish(contact_to_msg(state))
            deadline = time.monotonic() + WAIT_S
            while len(witnessed) < 20 and time.monotonic() < deadline:
                witness.spin_once(timeout_sec=0.05)
            assert len(witnessed) == 20
        except BaseException:
            witness.shutdown()
            controller.destroy_node()
            raise
    try:
        assert wait(lambda: len(taken) == 20)
        # All of them, in publication order, by one cycle.
        assert [stamp for stamp, _ in taken] == [1_000_000_000 + k for k in range(20)]
        assert len({cycle for _, cycle in taken}) == 1
    finally:
        witness.shutdown()
        peer.destroy_node()
        controller.destroy_node()
