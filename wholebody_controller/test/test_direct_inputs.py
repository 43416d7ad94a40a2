"""The controller node built for direct inputs (``direct_state_inputs``, phri_sim's lock-step
runner): joint states and odometry come only from its owner's calls, and the node subscribes
neither ``/joint_states`` nor ``/odom``; contact states still arrive on their topics."""

from __future__ import annotations

import pytest
from nav_msgs.msg import Odometry
from rclpy.parameter import Parameter
from sensor_msgs.msg import JointState
from wbc_fake_kinematics import FakeKinematics

from phri_common.testing import spin_until
from wholebody_controller.config import SKIN_LINKS
from wholebody_controller.node import WholeBodyControllerNode

ARM = [0.3, -1.2, 1.5, -1.0, -1.57, 0.0, -0.3, 1.2, -1.5, 1.0, 1.57, 0.0]


def _subscribed(node: WholeBodyControllerNode) -> set[str]:
    return {name for name, _ in node.get_subscriber_names_and_types_by_node(
        node.get_name(), node.get_namespace())}


@pytest.mark.ros
@pytest.mark.parametrize("loop", ["thread", "timer"])
def test_direct_inputs_subscribe_no_state_topics(ros_context: object, loop: str) -> None:
    """Built normally the node subscribes both state topics; for direct inputs it does not, and
    still subscribes every link's contact states."""
    from rclpy.executors import SingleThreadedExecutor

    overrides = [Parameter("control_loop", value=loop)]
    plain = WholeBodyControllerNode(kinematics=FakeKinematics(), context=ros_context,
                                    parameter_overrides=overrides)
    direct = WholeBodyControllerNode(kinematics=FakeKinematics(), context=ros_context,
                                     node_name="wbc_direct", direct_state_inputs=True,
                                     parameter_overrides=overrides)
    executor = SingleThreadedExecutor(context=ros_context)  # type: ignore[arg-type]
    try:
        contacts = {f"/contacts/{link}" for link in SKIN_LINKS}
        assert spin_until(executor, lambda: contacts <= _subscribed(direct), timeout_s=10.0)
        assert spin_until(executor, lambda: {"/joint_states", "/odom"} <= _subscribed(plain),
                          timeout_s=10.0)
        assert not {"/joint_states", "/odom"} & _subscribed(direct)
    finally:
        for node in (direct, plain):
            node.destroy_node()
        executor.shutdown()


@pytest.mark.ros
def test_direct_inputs_are_taken_from_the_owners_calls(ros_context: object) -> None:
    """on_joints / on_odom keep the arm positions and the base pose and mark them arrived."""
    node = WholeBodyControllerNode(kinematics=FakeKinematics(), context=ros_context,
                                   direct_state_inputs=True,
                                   parameter_overrides=[Parameter("control_loop", value="timer")])
    try:
        marks = (node.odom_time, min(node.arm_time))
        node.on_joints(JointState(name=list(node.arm_joints), position=ARM))
        odom = Odometry()
        odom.pose.pose.position.x = 0.25
        odom.pose.pose.orientation.w = 1.0
        node.on_odom(odom)
        assert node.arm_q.tolist() == ARM
        assert node.base_q[0] == 0.25
        assert node.odom_time != marks[0]
        assert min(node.arm_time) != marks[1]
    finally:
        node.destroy_node()
