"""The controller node checks the skin against the joints' external torques: a skin that reads
3 × or 0.3 × what the joints feel trips the safe stop (exact zero command, diagnostics ERROR);
a skin silent while the joints feel a contact is left to the unsensed guard while its back-off
relieves it, and is a verdict once backing off does not.

The node runs on a hand-driven clock (as in ``test_node_unsensed.py``); the efforts are the
gravity torques of the robot description minus the external torque the joints feel."""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np
import pytest
from diagnostic_msgs.msg import DiagnosticStatus
from std_srvs.srv import Trigger
from wbc_effort_node import PERIOD_NS, EffortNode, FloatArray

pytestmark = pytest.mark.ros


class Node(EffortNode):
    """The node recording its "safe stop" statuses."""

    def __init__(self, context: object, **params: object) -> None:
        super().__init__(context, "safe stop", **params)


@pytest.fixture
def node(ros_context: object) -> Iterator[Node]:
    n = Node(ros_context)
    yield n
    n.destroy_node()


def test_a_skin_that_agrees_with_the_joints_moves_the_robot(node: Node) -> None:
    for _ in range(100):  # 1 s
        command = node.period(20.0, node.felt(20.0))
    assert float(np.max(np.abs(command))) > 1e-3
    assert not node.safe_stop.active
    assert node.skin_check.ratio == pytest.approx(1.0, abs=0.05)


@pytest.mark.parametrize(("reads", "true"), [(36.0, 12.0), (12.0, 40.0)])
def test_a_skin_gain_far_off_trips_the_safe_stop(node: Node, reads: float, true: float) -> None:
    """The skin reads 3 × (36 N for 12 N) or 0.3 × (12 N for 40 N) what the joints feel."""
    cycles = 0
    while not node.safe_stop.active and cycles < 100:
        command = node.period(reads, node.felt(true))
        cycles += 1
    assert node.safe_stop.active and "gain_off" in node.safe_stop.reasons
    assert 0.3 <= cycles * PERIOD_NS * 1e-9 < 0.5  # skin_gain_hold_time (0.3 s) + the filter
    assert np.all(command == 0.0)  # exact zero in the verdict's own cycle
    for _ in range(10):
        assert np.all(node.period(reads, node.felt(true)) == 0.0)
    assert node.statuses[-1].level == DiagnosticStatus.ERROR
    assert "skin gain far off" in node.statuses[-1].message
    res = node._reset(Trigger.Request(), Trigger.Response())
    assert res.success and not node.safe_stop.active


def test_the_check_can_be_switched_off(ros_context: object) -> None:
    off = Node(ros_context, skin_torque_check=False)
    try:
        for _ in range(100):
            command = off.period(36.0, off.felt(12.0))
        assert not off.safe_stop.active and float(np.max(np.abs(command))) > 1e-3
    finally:
        off.destroy_node()


def wrist_push() -> FloatArray:
    """External torques of a 90 N push on the left wrist (no skin there): 80 N·m on the
    shoulder lift, beyond the guard's 45 N·m."""
    tau = np.zeros(15)
    tau[3:9] = [30.0, -80.0, 20.0, 5.0, -2.0, 0.5]
    return tau


def test_an_unsensed_push_that_backing_off_relieves_is_the_guards(node: Node) -> None:
    """A silent skin while the joints feel a push is what a contact on the wrist looks like:
    the guard stops and backs off; relieved within skin_silent_hold_time, no latched stop."""
    for _ in range(20):
        node.period(None, np.zeros(15))
    for _ in range(150):  # 1.5 s of backing off
        command = node.period(None, wrist_push())
    assert node.torque_watch.report.state.name == "STOPPED" and command[4] < 0.0
    for _ in range(100):
        node.period(None, np.zeros(15))
    assert node.torque_watch.report.state.name == "OK" and not node.safe_stop.active


def test_a_push_backing_off_does_not_relieve_trips_skin_silent(node: Node) -> None:
    for _ in range(20):
        node.period(None, np.zeros(15))
    cycles = 0
    while not node.safe_stop.active and cycles < 400:
        command = node.period(None, wrist_push())
        cycles += 1
    assert "skin_silent" in node.safe_stop.reasons
    assert 2.0 <= cycles * PERIOD_NS * 1e-9 < 2.1  # skin_silent_hold_time after the stop
    assert np.all(command == 0.0)


def test_with_the_guard_off_a_silent_skin_is_judged_at_once(ros_context: object) -> None:
    """Nothing backs away with ``unsensed_guard`` off: the silent skin is a verdict after
    skin_silent_hold_time of the push alone."""
    off = Node(ros_context, unsensed_guard=False)
    try:
        for _ in range(20):
            off.period(None, np.zeros(15))
        for _ in range(205):
            command = off.period(None, wrist_push())
        assert "skin_silent" in off.safe_stop.reasons and np.all(command == 0.0)
    finally:
        off.destroy_node()
