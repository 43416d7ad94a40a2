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
from nav_msgs.msg import Odometry
from numpy.typing import NDArray
from rclpy.parameter import Parameter
from rclpy.serialization import serialize_message
from sensor_msgs.msg import JointState
from std_srvs.srv import Trigger

from phri_common.contact import contact_to_msg
from phri_common.records import ContactState
from phri_description.description import JOINT_NAMES
from wholebody_controller.external_torque import ArmDynamics
from wholebody_controller.node import WholeBodyControllerNode

pytestmark = pytest.mark.ros

ARM = [0.0, -0.3, 0.3, 3.14159, 0.0, 0.0, 0.0, 0.3, -0.3, 0.0, 0.0, 0.0]
Q = np.array([0.0, 0.0, 0.0, *ARM])
CENTER = np.array([0.18, 0.0, 0.06])
LINK = "left_forearm_link"
PERIOD_NS = 10_000_000
FloatArray = NDArray[np.float64]


def touch(force: float, stamp: int) -> ContactState:
    """The skin's reading: ``force`` [N] pressing the left forearm at CENTER."""
    return ContactState(LINK, stamp, True, CENTER, np.array([0.0, -force, 0.0]), np.zeros(3),
                        CENTER - 0.02, CENTER + 0.02, 16)


class Node(WholeBodyControllerNode):
    """The node with its commands and diagnostics recorded."""

    def __init__(self, context: object, **params: object) -> None:
        self.now_ns = 1_000_000_000
        self.commands: list[FloatArray] = []
        self.statuses: list[DiagnosticStatus] = []
        overrides = [Parameter("control_loop", value="timer"),
                     Parameter("velocity_limit", value=0.15),
                     *(Parameter(k, value=v) for k, v in params.items())]
        super().__init__(context=context, clock_ns=lambda: self.now_ns,
                         parameter_overrides=overrides)
        self.dynamics = ArmDynamics()
        self.gravity = self.dynamics.needed(Q, np.zeros(15), np.zeros(15))
        self.diag_pub.publish = self._record  # type: ignore[method-assign]

    def _record(self, msg: object) -> None:
        self.statuses += [s for s in msg.status if s.name.endswith("safe stop")]  # type: ignore[attr-defined]

    def publish_command(self, command: FloatArray) -> None:
        self.commands.append(np.array(command))
        super().publish_command(command)

    def felt(self, force: float) -> FloatArray:
        """External torques (15, q order) of a true ``force`` [N] at the skin's CENTER."""
        return self.dynamics.skin_torques(Q, {LINK: touch(force, 0)})

    def cycle(self, skin_force: float | None, external: FloatArray) -> FloatArray:
        """One period: the skin reports ``skin_force`` [N] on the left forearm (None: no
        contact anywhere), the joints feel ``external`` [N·m] (15); the command."""
        self.now_ns += PERIOD_NS
        for link in self.links:
            state = ContactState.no_contact(link, self.now_ns)
            if link == LINK and skin_force is not None:
                state = touch(skin_force, self.now_ns)
            self.on_contact(link, contact_to_msg(state))
        js = JointState(name=list(JOINT_NAMES[3:]), position=ARM, velocity=[0.0] * 12,
                        effort=(self.gravity - external)[3:].tolist())
        self.on_joints_bytes(serialize_message(js))
        odom = Odometry()
        odom.pose.pose.orientation.w = 1.0
        self.on_odom(odom)
        self.tick()
        return self.commands[-1]


@pytest.fixture
def node(ros_context: object) -> Iterator[Node]:
    n = Node(ros_context)
    yield n
    n.destroy_node()


def test_a_skin_that_agrees_with_the_joints_moves_the_robot(node: Node) -> None:
    for _ in range(100):  # 1 s
        command = node.cycle(20.0, node.felt(20.0))
    assert float(np.max(np.abs(command))) > 1e-3
    assert not node.safe_stop.active
    assert node.skin_check.ratio == pytest.approx(1.0, abs=0.05)


@pytest.mark.parametrize(("reads", "true"), [(36.0, 12.0), (12.0, 40.0)])
def test_a_skin_gain_far_off_trips_the_safe_stop(node: Node, reads: float, true: float) -> None:
    """The skin reads 3 × (36 N for 12 N) or 0.3 × (12 N for 40 N) what the joints feel."""
    cycles = 0
    while not node.safe_stop.active and cycles < 100:
        command = node.cycle(reads, node.felt(true))
        cycles += 1
    assert node.safe_stop.active and "gain_off" in node.safe_stop.reasons
    assert 0.3 <= cycles * PERIOD_NS * 1e-9 < 0.5  # skin_gain_hold_time (0.3 s) + the filter
    assert np.all(command == 0.0)  # exact zero in the verdict's own cycle
    for _ in range(10):
        assert np.all(node.cycle(reads, node.felt(true)) == 0.0)
    assert node.statuses[-1].level == DiagnosticStatus.ERROR
    assert "skin gain far off" in node.statuses[-1].message
    res = node._reset(Trigger.Request(), Trigger.Response())
    assert res.success and not node.safe_stop.active


def test_the_check_can_be_switched_off(ros_context: object) -> None:
    off = Node(ros_context, skin_torque_check=False)
    try:
        for _ in range(100):
            command = off.cycle(36.0, off.felt(12.0))
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
        node.cycle(None, np.zeros(15))
    for _ in range(150):  # 1.5 s of backing off
        command = node.cycle(None, wrist_push())
    assert node.torque_watch.report.state.name == "STOPPED" and command[4] < 0.0
    for _ in range(100):
        node.cycle(None, np.zeros(15))
    assert node.torque_watch.report.state.name == "OK" and not node.safe_stop.active


def test_a_push_backing_off_does_not_relieve_trips_skin_silent(node: Node) -> None:
    for _ in range(20):
        node.cycle(None, np.zeros(15))
    cycles = 0
    while not node.safe_stop.active and cycles < 400:
        command = node.cycle(None, wrist_push())
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
            off.cycle(None, np.zeros(15))
        for _ in range(205):
            command = off.cycle(None, wrist_push())
        assert "skin_silent" in off.safe_stop.reasons and np.all(command == 0.0)
    finally:
        off.destroy_node()
