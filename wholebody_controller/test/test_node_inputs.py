"""The controller node's input boundary, cycle by cycle: physically impossible inputs
are refused (zero command, a clear error) and the next good message recovers; a failed QP never
wedges the controller; under fuzzed inputs no command is ever non-finite or over the limits.

The node runs with a hand-driven clock and its callbacks and ``tick`` are called directly, so
every assertion is about one precise control period."""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np
import pytest
from geometry_msgs.msg import Twist
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from nav_msgs.msg import Odometry
from numpy.typing import NDArray
from rclpy.parameter import Parameter
from rclpy.serialization import deserialize_message, serialize_message
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray
from wbc_fake_kinematics import FakeKinematics

from phri_common.contact import contact_to_msg
from phri_common.records import ContactState
from wholebody_controller.messages import arm_command, command_to_twist
from wholebody_controller.node import WholeBodyControllerNode
from wholebody_controller.qp import QPError

pytestmark = pytest.mark.ros

ARM = [0.3, -1.2, 1.5, -1.0, -1.57, 0.0, -0.3, 1.2, -1.5, 1.0, 1.57, 0.0]
CENTER = np.array([-0.15, 0.0, 0.05])
PUSH = np.array([0.0, 0.0, 12.0])
PERIOD_NS = 10_000_000


class RecordingNode(WholeBodyControllerNode):
    """The node with its commands recorded instead of only published."""

    def __init__(self, context: object) -> None:
        self.now_ns = 1_000_000_000
        self.commands: list[NDArray[np.float64]] = []
        # The cycles are driven by hand: the executor timer mode (not spun) runs none itself.
        super().__init__(kinematics=FakeKinematics(), context=context,
                         clock_ns=lambda: self.now_ns,
                         parameter_overrides=[Parameter("control_loop", value="timer")])

    def publish_command(self, command: NDArray[np.float64]) -> None:
        self.commands.append(np.array(command))
        super().publish_command(command)

    def feed(self, force: NDArray[np.float64] | None = PUSH, joints: list[float] | None = None,
             odom_x: float = 0.0, serialized: bool = False) -> None:
        """One period's inputs (contacts on every link, joint states, odometry)."""
        for link in self.links:
            state = ContactState.no_contact(link, self.now_ns)
            if link == "left_forearm_link" and force is not None:
                state = ContactState(link, self.now_ns, True, CENTER, force, np.zeros(3),
                                     CENTER - 0.02, CENTER + 0.02, 16)
            self.on_contact(link, contact_to_msg(state))
        js = JointState(name=list(self.arm_joints), position=joints or ARM)
        odom = Odometry()
        odom.pose.pose.position.x = odom_x
        odom.pose.pose.orientation.w = 1.0
        if serialized:  # the subscriptions' path (raw=True)
            self.on_joints_bytes(serialize_message(js))
            self.on_odom_bytes(serialize_message(odom))
        else:
            self.on_joints(js)
            self.on_odom(odom)

    def cycle(self, **inputs: object) -> NDArray[np.float64]:
        """Advance one period, feed the inputs, run one control cycle; its command."""
        self.now_ns += PERIOD_NS
        self.feed(**inputs)  # type: ignore[arg-type]
        self.tick()
        return self.commands[-1]


@pytest.fixture
def node(ros_context: object) -> Iterator[RecordingNode]:
    n = RecordingNode(ros_context)
    yield n
    n.destroy_node()


def moving(command: NDArray[np.float64]) -> bool:
    return float(np.max(np.abs(command))) > 1e-4


def test_joint_outside_its_limits_gives_zero_then_recovers(node: RecordingNode) -> None:
    for _ in range(5):
        assert moving(node.cycle())
    refused = node.rejected_inputs
    bad = list(ARM)
    bad[2] = 10.0  # left elbow at 10 rad, limit ±π
    assert not moving(node.cycle(joints=bad))
    assert node.rejected_inputs == refused + 1
    assert moving(node.cycle())  # the next good message: commands again, in one period


def test_absurd_contact_force_is_refused_and_the_next_good_one_commands(
        node: RecordingNode) -> None:
    for _ in range(5):
        node.cycle()
    assert not moving(node.cycle(force=np.array([0.0, 0.0, 1e19])))
    assert moving(node.cycle())


class FailingSolver:
    name = "failing"

    def solve(self, problem: object) -> NDArray[np.float64]:
        raise QPError("injected failure")


def test_a_failed_qp_resets_the_tasks_and_the_next_good_cycle_commands(
        node: RecordingNode) -> None:
    controller = node.controller
    assert controller is not None
    for _ in range(5):
        node.cycle()
    assert controller.tasks[1].locked_reference is not None  # the pushed link is active
    solver, controller.solver = controller.solver, FailingSolver()
    assert not moving(node.cycle())
    assert node.qp_failures == 1
    assert all(t.locked_reference is None for t in controller.tasks)  # reset
    controller.solver = solver
    assert moving(node.cycle())


def test_odometry_jump_is_refused_once(node: RecordingNode) -> None:
    for _ in range(3):
        node.cycle()
    refused = node.rejected_inputs
    assert not moving(node.cycle(odom_x=3.0))
    assert node.rejected_inputs == refused + 1
    assert moving(node.cycle(odom_x=3.0))  # continuous from the jump on: accepted


contact_values = st.one_of(st.floats(-300.0, 300.0), st.sampled_from(
    [np.nan, np.inf, -np.inf, 1e19, -3e38, 6000.0]))
joint_values = st.one_of(st.floats(-3.0, 3.0), st.sampled_from([np.nan, 10.0, -1e9]))


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow,
                                                                  HealthCheck.function_scoped_fixture])
@given(st.lists(st.tuples(st.lists(contact_values, min_size=3, max_size=3),
                          st.integers(0, 11), joint_values, st.floats(-1.0, 1.0)),
                min_size=1, max_size=25))
def test_fuzzed_inputs_never_give_a_bad_command_nor_wedge(
        node: RecordingNode, sequence: list[tuple[list[float], int, float, float]]) -> None:
    limit = float(node.params["velocity_limit"])
    node.controller.reset()  # type: ignore[union-attr]
    for force, joint, value, odom_x in sequence:
        joints = list(ARM)
        joints[joint] = value
        command = node.cycle(force=np.array(force), joints=joints, odom_x=odom_x)
        assert np.all(np.isfinite(command))
        assert np.all(np.abs(command) <= limit + 1e-9)
    # Good input again: the robot is commanded within a few periods (no wedge).
    assert any(moving(node.cycle(odom_x=odom_x)) for _ in range(5))


def test_per_axis_velocity_limits_reach_the_controller(node: RecordingNode) -> None:
    from rclpy.parameter import Parameter

    limits = [0.5, 0.4, 1.0] + [0.3] * 12
    result = node.set_parameters([Parameter("velocity_limit", value=3.0),
                                  Parameter("velocity_limits", value=limits)])
    assert all(r.successful for r in result)
    assert node.controller is not None
    np.testing.assert_allclose(node.controller.velocity_upper,
                               np.minimum(limits, node.kinematics.velocity_limits))
    result = node.set_parameters([Parameter("velocity_limits", value=[0.5] * 14)])
    assert not result[0].successful and "velocity_limits" in result[0].reason


def test_serialized_inputs_command_as_the_messages_do(ros_context: object) -> None:
    """The raw=True path (phri_common.cdr) and the message path: the same commands, cycle by
    cycle, through a refused joint state (F9) and an odometry jump."""
    runs = []
    for serialized in (False, True):
        n = RecordingNode(ros_context)
        bad = list(ARM)
        bad[2] = 10.0
        inputs = [{}, {}, {"joints": bad}, {}, {"odom_x": 3.0}, {"odom_x": 3.0}, {}, {}]
        runs.append([n.cycle(serialized=serialized, **kw) for kw in inputs])  # type: ignore
        n.destroy_node()
    np.testing.assert_array_equal(np.array(runs[0]), np.array(runs[1]))
    assert moving(runs[1][1]) and not moving(runs[1][2]) and not moving(runs[1][4])


@pytest.mark.parametrize("which", ["joints", "odometry"])
def test_unreadable_serialized_input_is_refused_then_recovers(
        node: RecordingNode, which: str) -> None:
    for _ in range(3):
        assert moving(node.cycle(serialized=True))
    refused = node.rejected_inputs
    node.now_ns += PERIOD_NS
    node.feed(serialized=True)
    garbage = b"\x00\x01\x00\x00" + b"\xff" * 12  # a frame_id length of 4 GB
    (node.on_joints_bytes if which == "joints" else node.on_odom_bytes)(garbage)
    node.tick()
    assert not moving(node.commands[-1])  # F9: refused = never received: zero this cycle
    assert node.rejected_inputs == refused + 1
    assert moving(node.cycle(serialized=True))  # the next good message recovers


def test_commands_are_published_as_the_reference_messages(node: RecordingNode) -> None:
    """The serialized commands (phri_common.cdr) read back as messages.command_to_twist and
    messages.arm_command build them."""
    sent: dict[str, list[object]] = {"cmd": [], "left": [], "right": []}
    for key, pub in (("cmd", node.cmd_pub), ("left", node.left_pub), ("right", node.right_pub)):
        pub.publish = sent[key].append  # type: ignore[method-assign]
    command = node.cycle()
    assert moving(command)
    twist = deserialize_message(sent["cmd"][-1], Twist)  # type: ignore[arg-type]
    left = deserialize_message(sent["left"][-1], Float64MultiArray)  # type: ignore[arg-type]
    right = deserialize_message(sent["right"][-1], Float64MultiArray)  # type: ignore[arg-type]
    assert twist == command_to_twist(command)
    assert left == arm_command(command[3:9], node.left_joints)
    assert right == arm_command(command[9:15], node.right_joints)


def test_a_burst_of_contact_states_is_queued_not_dropped(ros_context: object) -> None:
    """States published while the controller is held off the CPU (a 40 ms stall at 500 Hz: 20
    states of a link) all reach it when it runs again: with the sensor-data depth of 5 the DDS
    queue kept only the last 5 (bench_chain's dropped frames). The controller is spun only once
    a witness in the same process has all 20 (so all 20 have reached the controller's reader)."""
    import time

    from rclpy.executors import SingleThreadedExecutor
    from rclpy.node import Node
    from rclpy.qos import QoSProfile
    from sensor_msgs.msg import PointCloud2

    from wholebody_controller.qos import CONTACT_QOS

    wait_s = 60.0  # bounds a stalled machine only
    controller = RecordingNode(ros_context)
    peer = Node("contact_burst_peer", context=ros_context)  # type: ignore[arg-type]
    link = "left_forearm_link"
    pub = peer.create_publisher(PointCloud2, f"contacts/{link}", QoSProfile(depth=50))
    witnessed: list[PointCloud2] = []
    peer.create_subscription(PointCloud2, f"contacts/{link}", witnessed.append,
                             QoSProfile(depth=50, reliability=CONTACT_QOS.reliability))
    received: list[bytes] = []
    controller.on_contact_bytes = lambda lk, data: received.append(data)  # type: ignore[method-assign]
    executor = SingleThreadedExecutor(context=ros_context)  # type: ignore[arg-type]
    executor.add_node(controller)
    witness = SingleThreadedExecutor(context=ros_context)  # type: ignore[arg-type]
    witness.add_node(peer)
    try:
        deadline = time.monotonic() + wait_s
        while pub.get_subscription_count() < 2 and time.monotonic() < deadline:
            time.sleep(0.01)
        assert pub.get_subscription_count() >= 2, "no discovery"
        for k in range(20):
            state = ContactState(link, 1_000_000_000 + 2_000_000 * k, True, CENTER, PUSH,
                                 np.zeros(3), CENTER - 0.02, CENTER + 0.02, 16)
            pub.publish(contact_to_msg(state))
        # The controller does not spin meanwhile: the states wait in its reader queue.
        deadline = time.monotonic() + wait_s
        while len(witnessed) < 20 and time.monotonic() < deadline:
            witness.spin_once(timeout_sec=0.05)
        assert len(witnessed) == 20
        deadline = time.monotonic() + wait_s
        while len(received) < 20 and time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.05)
        assert len(received) == 20
    finally:
        witness.shutdown()
        executor.shutdown()
        peer.destroy_node()
        controller.destroy_node()
