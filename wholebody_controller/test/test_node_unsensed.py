"""The controller node against contacts no skin feels: it reads the arms' efforts from
``/joint_states``, stops the base and backs the arm off along an unexplained torque, says so on
``/diagnostics`` at once, and commands again once it is gone.

The node runs on a hand-driven clock; its callbacks and ``tick`` are called directly, so every
assertion is about one precise control period. Efforts are what the arms would report at rest:
the gravity torques of the robot description, minus the external torque of a push."""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np
import pytest
from diagnostic_msgs.msg import DiagnosticStatus
from wbc_effort_node import EffortNode, FloatArray

pytestmark = pytest.mark.ros


class Node(EffortNode):
    """The node recording its "unsensed contact" statuses."""

    def __init__(self, context: object, **params: object) -> None:
        super().__init__(context, "unsensed contact", **params)


@pytest.fixture
def node(ros_context: object) -> Iterator[Node]:
    n = Node(ros_context)
    yield n
    n.destroy_node()


def wrist_push() -> FloatArray:
    """External torques of a 90 N push on the left wrist: 80 N·m on the shoulder lift, beyond
    its 45 N·m."""
    tau = np.zeros(15)
    tau[3:9] = [30.0, -80.0, 20.0, 5.0, -2.0, 0.5]
    return tau


def test_the_touch_alone_moves_the_robot(node: Node) -> None:
    """The skin's own contact is explained: no stop, the robot follows the touch."""
    for _ in range(20):
        command = node.period(12.0, np.zeros(15))
    assert float(np.max(np.abs(command))) > 1e-3
    assert node.torque_watch.report.state.name == "OK"


def test_an_unsensed_push_stops_the_base_backs_off_and_resumes(node: Node) -> None:
    for _ in range(20):
        node.period(12.0, np.zeros(15))
    command = node.period(12.0, wrist_push())  # the estimate's low-pass (20 ms): slowing at first
    assert node.torque_watch.report.state.name == "SLOWING"
    assert node.statuses[-1].level == DiagnosticStatus.WARN  # published at once
    command = node.period(12.0, wrist_push())
    assert node.torque_watch.report.state.name == "STOPPED"
    assert np.max(np.abs(command[:3])) < 1e-9  # the base stops at once
    assert command[4] <= 0.0  # never on into the push (−80 N·m on the shoulder lift)
    assert node.statuses[-1].level == DiagnosticStatus.ERROR  # published at once
    assert "left_shoulder_lift_joint" in node.statuses[-1].message
    for _ in range(10):
        command = node.period(12.0, wrist_push())
    assert np.max(np.abs(command[:3])) < 1e-9
    assert command[4] < 0.0  # backing off along the torque, built up at the rated acceleration
    for _ in range(60):  # gone for longer than unsensed_resume_time (0.5 s)
        command = node.period(12.0, np.zeros(15))
    assert node.torque_watch.report.state.name == "OK"
    assert float(np.max(np.abs(command))) > 1e-3  # commands again
    assert node.torque_watch.report.stops == 1


def test_without_efforts_the_arms_are_reported_unguarded(node: Node) -> None:
    for _ in range(3):
        node.period(12.0, wrist_push(), efforts=False)
    assert node.torque_watch.report.state.name == "OK"
    node.publish_diagnostics()
    assert node.statuses[-1].level == DiagnosticStatus.WARN
    assert "unguarded" in node.statuses[-1].message


def test_the_guard_can_be_switched_off(ros_context: object) -> None:
    off = Node(ros_context, unsensed_guard=False)
    try:
        for _ in range(20):
            off.period(12.0, np.zeros(15))
        for _ in range(5):
            command = off.period(12.0, wrist_push())
        assert float(np.max(np.abs(command[:3]))) > 1e-3  # the base drives on
        assert off.torque_watch.report.ratio > 1.0  # but the estimate still says it
    finally:
        off.destroy_node()
