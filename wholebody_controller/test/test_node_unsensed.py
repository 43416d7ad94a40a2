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
from nav_msgs.msg import Odometry
from numpy.typing import NDArray
from rclpy.parameter import Parameter
from rclpy.serialization import serialize_message
from sensor_msgs.msg import JointState

from phri_common.contact import contact_to_msg
from phri_common.records import ContactState
from phri_description.description import JOINT_NAMES
from wholebody_controller.external_torque import ArmDynamics
from wholebody_controller.node import WholeBodyControllerNode

pytestmark = pytest.mark.ros

ARM = [0.0, -0.3, 0.3, 3.14159, 0.0, 0.0, 0.0, 0.3, -0.3, 0.0, 0.0, 0.0]
Q = np.array([0.0, 0.0, 0.0, *ARM])
CENTER = np.array([0.18, 0.0, 0.06])
PERIOD_NS = 10_000_000


class Node(WholeBodyControllerNode):
    """The node with its commands and diagnostics recorded."""

    def __init__(self, context: object, **params: object) -> None:
        self.now_ns = 1_000_000_000
        self.commands: list[NDArray[np.float64]] = []
        self.statuses: list[DiagnosticStatus] = []
        overrides = [Parameter("control_loop", value="timer"),
                     Parameter("velocity_limit", value=0.15),
                     *(Parameter(k, value=v) for k, v in params.items())]
        super().__init__(context=context, clock_ns=lambda: self.now_ns,
                         parameter_overrides=overrides)
        self.gravity = ArmDynamics().needed(Q, np.zeros(15), np.zeros(15))
        self.diag_pub.publish = self._record  # type: ignore[method-assign]

    def _record(self, msg: object) -> None:
        self.statuses += [s for s in msg.status if s.name.endswith("unsensed contact")]  # type: ignore[attr-defined]

    def publish_command(self, command: NDArray[np.float64]) -> None:
        self.commands.append(np.array(command))
        super().publish_command(command)

    def cycle(self, external: NDArray[np.float64], efforts: bool = True) -> NDArray[np.float64]:
        """One period: a 12 N skin touch on the left forearm (the robot moves), joint states
        with the efforts of a push of ``external`` [N·m] (15, q order), odometry; the command."""
        self.now_ns += PERIOD_NS
        for link in self.links:
            state = ContactState.no_contact(link, self.now_ns)
            if link == "left_forearm_link":
                state = ContactState(link, self.now_ns, True, CENTER, np.array([0, -12.0, 0]),
                                     np.zeros(3), CENTER - 0.02, CENTER + 0.02, 16)
            self.on_contact(link, contact_to_msg(state))
        effort = (self.gravity - external)[3:].tolist() if efforts else []
        js = JointState(name=list(JOINT_NAMES[3:]), position=ARM, velocity=[0.0] * 12,
                        effort=effort)
        self.on_joints_bytes(serialize_message(js))  # the subscription's path: CDR with efforts
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


def wrist_push() -> NDArray[np.float64]:
    """External torques of a 90 N push on the left wrist: 80 N·m on the shoulder lift, beyond
    its 45 N·m."""
    tau = np.zeros(15)
    tau[3:9] = [30.0, -80.0, 20.0, 5.0, -2.0, 0.5]
    return tau


def test_the_touch_alone_moves_the_robot(node: Node) -> None:
    """The skin's own contact is explained: no stop, the robot follows the touch."""
    for _ in range(20):
        command = node.cycle(np.zeros(15))
    assert float(np.max(np.abs(command))) > 1e-3
    assert node.torque_watch.report.state.name == "OK"


def test_an_unsensed_push_stops_the_base_backs_off_and_resumes(node: Node) -> None:
    for _ in range(20):
        node.cycle(np.zeros(15))
    command = node.cycle(wrist_push())  # the estimate's low-pass (20 ms): slowing at first
    assert node.torque_watch.report.state.name == "SLOWING"
    assert node.statuses[-1].level == DiagnosticStatus.WARN  # published at once
    command = node.cycle(wrist_push())
    assert node.torque_watch.report.state.name == "STOPPED"
    assert np.max(np.abs(command[:3])) < 1e-9  # the base stops at once
    assert command[4] <= 0.0  # never on into the push (−80 N·m on the shoulder lift)
    assert node.statuses[-1].level == DiagnosticStatus.ERROR  # published at once
    assert "left_shoulder_lift_joint" in node.statuses[-1].message
    for _ in range(10):
        command = node.cycle(wrist_push())
    assert np.max(np.abs(command[:3])) < 1e-9
    assert command[4] < 0.0  # backing off along the torque, built up at the rated acceleration
    for _ in range(60):  # gone for longer than unsensed_resume_time (0.5 s)
        command = node.cycle(np.zeros(15))
    assert node.torque_watch.report.state.name == "OK"
    assert float(np.max(np.abs(command))) > 1e-3  # commands again
    assert node.torque_watch.report.stops == 1


def test_without_efforts_the_arms_are_reported_unguarded(node: Node) -> None:
    for _ in range(3):
        node.cycle(wrist_push(), efforts=False)
    assert node.torque_watch.report.state.name == "OK"
    node.publish_diagnostics()
    assert node.statuses[-1].level == DiagnosticStatus.WARN
    assert "unguarded" in node.statuses[-1].message


def test_the_guard_can_be_switched_off(ros_context: object) -> None:
    off = Node(ros_context, unsensed_guard=False)
    try:
        for _ in range(20):
            off.cycle(np.zeros(15))
        for _ in range(5):
            command = off.cycle(wrist_push())
        assert float(np.max(np.abs(command[:3]))) > 1e-3  # the base drives on
        assert off.torque_watch.report.ratio > 1.0  # but the estimate still says it
    finally:
        off.destroy_node()
