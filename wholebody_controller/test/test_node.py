"""The controller node in an isolated ROS domain: contact in → command out, stale input → zero,
NaN input refused while the node stays up, parameters validated, zero on shutdown."""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Iterator

import numpy as np
import pytest
from geometry_msgs.msg import Twist
from nav_msgs.msg import Odometry
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from sensor_msgs.msg import JointState, PointCloud2
from std_msgs.msg import Float64MultiArray
from std_srvs.srv import Trigger
from wbc_fake_kinematics import FakeKinematics

from phri_common.contact import contact_to_msg
from phri_common.records import ContactState
from phri_common.testing import spin_until
from wholebody_controller.config import SKIN_LINKS
from wholebody_controller.messages import msg_to_task_state
from wholebody_controller.node import WholeBodyControllerNode

ARM = [0.3, -1.2, 1.5, -1.0, -1.57, 0.0, -0.3, 1.2, -1.5, 1.0, 1.57, 0.0]
CENTER = np.array([-0.15, 0.0, 0.05])
WAIT_S = 60.0
"""Longest wait for something that must happen (a stalled machine); never a measured time."""


class Harness:
    def __init__(self, context: object, node: WholeBodyControllerNode | None = None) -> None:
        self.node = node or WholeBodyControllerNode(kinematics=FakeKinematics(), context=context)
        self.peer = Node("wbc_test_peer", context=context)
        self.executor = SingleThreadedExecutor(context=context)  # type: ignore[arg-type]
        self.executor.add_node(self.node)
        self.executor.add_node(self.peer)
        self.joints_pub = self.peer.create_publisher(JointState, "/joint_states", 10)
        self.odom_pub = self.peer.create_publisher(Odometry, "/odom", 10)
        self.contact_pubs = {
            link: self.peer.create_publisher(PointCloud2, f"contacts/{link}", 10)
            for link in SKIN_LINKS
        }
        self.twists: list[Twist] = []
        self.left: list[Float64MultiArray] = []
        self.states: list[PointCloud2] = []
        self.peer.create_subscription(Twist, "/cmd_vel", self.twists.append, 10)
        self.peer.create_subscription(
            Float64MultiArray, "left/forward_velocity_controller/commands", self.left.append, 10
        )
        self.peer.create_subscription(
            PointCloud2, "/wholebody_controller/state/left_forearm_link", self.states.append, 10
        )
        self.joint_names = list(self.node.arm_joints)
        self.node_destroyed = False

    def publish_inputs(self, force: np.ndarray | None, contacts: bool = True,
                       joints: list[float] | None = None) -> None:
        stamp = self.peer.get_clock().now().to_msg()
        js = JointState(name=self.joint_names, position=joints or ARM)
        js.header.stamp = stamp
        self.joints_pub.publish(js)
        odom = Odometry()
        odom.pose.pose.orientation.w = 1.0
        self.odom_pub.publish(odom)
        if not contacts:
            return
        for link, pub in self.contact_pubs.items():
            if link == "left_forearm_link" and force is not None:
                state = ContactState(link, 1, True, CENTER, force, np.zeros(3), CENTER - 0.02,
                                     CENTER + 0.02, 16)
            else:
                state = ContactState.no_contact(link, 1)
            pub.publish(contact_to_msg(state))

    def run(self, until: Callable[[], bool], timeout: float = WAIT_S, **inputs: object) -> bool:
        """Publish the inputs every 10 ms and spin until ``until()`` (``timeout`` [s] only
        bounds a stalled machine)."""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            self.publish_inputs(**inputs)  # type: ignore[arg-type]
            end = time.monotonic() + 0.01
            while time.monotonic() < end:
                self.executor.spin_once(timeout_sec=0.002)
            if until():
                return True
        return until()

    def close(self) -> None:
        self.executor.shutdown()
        if not self.node_destroyed:
            self.node.destroy_node()
        self.peer.destroy_node()


@pytest.fixture(params=["thread", "timer"])
def harness(ros_context: object, request: pytest.FixtureRequest) -> Iterator[Harness]:
    """The node on the wall clock with each control loop (module docstring of node.py)."""
    node = WholeBodyControllerNode(
        kinematics=FakeKinematics(), context=ros_context,
        parameter_overrides=[Parameter("control_loop", value=request.param)])
    assert node.control_loop == request.param
    h = Harness(ros_context, node)
    yield h
    h.close()


def nonzero(msgs: list[Float64MultiArray]) -> bool:
    return bool(msgs) and max(abs(v) for v in msgs[-1].data) > 1e-4


@pytest.mark.ros
def test_contact_in_command_out_then_stale_contact_gives_zero(harness: Harness) -> None:
    # The task state is published only once its subscriber is matched: wait for both.
    assert harness.run(lambda: nonzero(harness.left) and bool(harness.states),
                       force=np.array([0.0, 0.0, 12.0]))
    state = msg_to_task_state(harness.states[-1])
    assert state["psi"] > 1e-4 and state["in_contact"] == 1.0
    assert len(harness.left[-1].data) == 6
    # Contacts stop arriving (joints and odometry keep coming) → zero (how soon: the sim-time
    # test below and test_freshness).
    zero_before = harness.node.zero_cycles
    assert harness.run(lambda: harness.node.zero_cycles > zero_before and not nonzero(harness.left)
                       and abs(harness.twists[-1].linear.x) + abs(harness.twists[-1].linear.y)
                       == 0.0,
                       force=None, contacts=False)
    # Inputs come back → commands again.
    assert harness.run(lambda: nonzero(harness.left), force=np.array([0.0, 0.0, 12.0]))


@pytest.mark.ros
def test_nan_input_refused_node_stays_alive(harness: Harness) -> None:
    assert harness.run(lambda: harness.node.good_cycles > 3, force=None)
    bad = list(ARM)
    bad[2] = math.nan
    assert harness.run(lambda: harness.node.rejected_inputs > 0, force=None, joints=bad)
    # NaN joints never updated the state: still the good values, and good cycles resume.
    assert np.all(np.isfinite(harness.node.arm_q))
    good = harness.node.good_cycles
    assert harness.run(lambda: harness.node.good_cycles > good + 3, force=None)
    # A NaN contact state is refused too.
    msg = contact_to_msg(ContactState("left_forearm_link", 1, True, CENTER,
                                      np.array([1.0, 0.0, 0.0]), np.zeros(3), CENTER, CENTER, 1))
    data = bytearray(msg.data)
    data[0:8] = np.array([math.nan]).tobytes()
    msg.data = bytes(data)
    rejected = harness.node.rejected_inputs
    harness.contact_pubs["left_forearm_link"].publish(msg)
    assert harness.run(lambda: harness.node.rejected_inputs > rejected, force=None,
                       contacts=False)


@pytest.mark.ros
def test_parameters_validated_and_applied(harness: Harness) -> None:
    node = harness.node
    result = node.set_parameters([Parameter("left_forearm_link.damping", value=[-1.0] * 6)])
    assert not result[0].successful and "left_forearm_link.damping" in result[0].reason
    result = node.set_parameters([Parameter("solver", value="quadprog")])
    assert not result[0].successful and "solver" in result[0].reason
    # A desired force of 10 N where there was none loosens a protected setting: refused until
    # the explicit unlock (Protected settings), then accepted.
    result = node.set_parameters([Parameter("left_forearm_link.desired_force",
                                            value=[0.0, -10.0, 0.0])])
    assert not result[0].successful and "safety_settings_unlocked" in result[0].reason
    result = node.set_parameters([Parameter("safety_settings_unlocked", value=True),
                                  Parameter("left_forearm_link.priority_lock", value=1.0),
                                  Parameter("left_forearm_link.desired_force",
                                            value=[0.0, -10.0, 0.0]),
                                  Parameter("solver", value="osqp")])
    assert all(r.successful for r in result)
    assert node.controller is not None
    cfg = node.controller.config.link("left_forearm_link")
    assert cfg.priority_lock == 1.0 and cfg.desired_force == (0.0, -10.0, 0.0)
    assert node.controller.solver.name == "osqp"
    # The input timeouts reach the freshness rules at run time, each to its own input.
    result = node.set_parameters([Parameter("contact_timeout", value=0.5),
                                  Parameter("joint_state_timeout", value=0.25),
                                  Parameter("odom_timeout", value=0.75)])
    assert all(r.successful for r in result)
    config = node.freshness.config
    assert (config.contact_timeout, config.joint_state_timeout, config.odom_timeout) == (
        0.5, 0.25, 0.75)


ATTACKS = [("left_forearm_link.force_limit", 10_000.0), ("yield_speed", 0.0),
           ("contact_timeout", 10.0), ("joint_state_timeout", 10.0), ("odom_timeout", 10.0),
           ("left_forearm_link.desired_force", [0.0, -1000.0, 0.0]),
           ("max_contact_force", 1e6), ("yield_speed_max", 0.0), ("regain_time", 60.0)]
"""The reviewer's run-time changes that switched the safety settings off quietly."""


@pytest.mark.ros
def test_protected_settings_are_not_loosened_at_run_time_without_the_unlock(
        ros_context: object) -> None:
    """Each loosening over the parameter services is refused, naming the setting and the
    unlock; tightening needs no unlock; after the explicit unlock the loosening is accepted
    (and logged), except a force limit above the ISO/TS 15066 table, which needs the
    start-up override as well."""
    node = WholeBodyControllerNode(kinematics=FakeKinematics(), context=ros_context)
    try:
        for name, value in ATTACKS:
            result = node.set_parameters([Parameter(name, value=value)])[0]
            assert not result.successful and name in result.reason, (name, result.reason)
            assert "safety_settings_unlocked" in result.reason
            assert node.get_parameter(name).value != value
        assert node.controller is not None
        assert node.controller.config.link("left_forearm_link").force_limit == 110.0
        tighter = node.set_parameters([Parameter("left_forearm_link.force_limit", value=90.0),
                                       Parameter("contact_timeout", value=0.05),
                                       Parameter("yield_speed", value=0.3)])
        assert all(r.successful for r in tighter)
        assert node.set_parameters([Parameter("safety_settings_unlocked", value=True)])[
            0].successful
        for name, value in ATTACKS[1:]:
            assert node.set_parameters([Parameter(name, value=value)])[0].successful, name
        above = node.set_parameters([Parameter("left_forearm_link.force_limit",
                                               value=200.0)])[0]
        assert not above.successful and "iso15066_override" in above.reason
        assert node.set_parameters([Parameter("left_forearm_link.force_limit", value=110.0)])[
            0].successful
        assert node.set_parameters([Parameter("safety_settings_unlocked", value=False)])[
            0].successful
        assert not node.set_parameters([Parameter("odom_timeout", value=20.0)])[0].successful
    finally:
        node.destroy_node()


@pytest.mark.ros
def test_force_limits_above_the_iso_table_need_the_start_up_override(
        ros_context: object, capfd: pytest.CaptureFixture[str]) -> None:
    raised = [Parameter("left_forearm_link.force_limit", value=150.0),
              Parameter("left_forearm_link.transient_force_limit", value=300.0)]
    with pytest.raises(ValueError, match="iso15066_override"):
        WholeBodyControllerNode(kinematics=FakeKinematics(), context=ros_context,
                                node_name="wbc_iso_refused", parameter_overrides=raised)
    node = WholeBodyControllerNode(
        kinematics=FakeKinematics(), context=ros_context, node_name="wbc_iso_override",
        parameter_overrides=[*raised, Parameter("iso15066_override", value=True)])
    try:
        assert node.controller is not None
        assert node.controller.config.link("left_forearm_link").force_limit == 150.0
        err = capfd.readouterr().err
        assert "ERROR" in err and "iso15066_override" in err and "150 N (table 110 N)" in err
    finally:
        node.destroy_node()


@pytest.mark.ros
def test_a_safe_stop_sends_an_exact_zero_until_reset(harness: Harness) -> None:
    """A plausibility verdict (e.g. the skin-vs-torque check) trips the safe stop: every output
    exactly zero — no band keeping, no task — and diagnostics ERROR, until ~/reset."""
    node = harness.node
    assert harness.run(lambda: nonzero(harness.left), force=np.array([0.0, 0.0, 12.0]))
    node.trip_safe_stop("skin_silent", "test verdict")
    count = len(harness.left)
    assert harness.run(lambda: len(harness.left) > count + 5, force=np.array([0.0, 0.0, 12.0]))
    assert all(v == 0.0 for msg in harness.left[count + 2:] for v in msg.data)
    assert harness.twists[-1].linear.x == 0.0 and harness.twists[-1].angular.z == 0.0
    from wholebody_controller.messages import safe_stop_status
    assert safe_stop_status("n", node.safe_stop).level == b"\x02"  # ERROR
    res = node._reset(Trigger.Request(), Trigger.Response())
    assert res.success and "skin_silent" in res.message and not node.safe_stop.active
    assert harness.run(lambda: nonzero(harness.left), force=np.array([0.0, 0.0, 12.0]))


@pytest.mark.ros
def test_record_q_dance_and_shutdown_zero(harness: Harness) -> None:
    node = harness.node
    res = node._record_q_dance(Trigger.Request(), Trigger.Response())
    assert not res.success and "every arm joint" in res.message  # no joint state yet (F4)
    assert harness.run(lambda: node.good_cycles > 2, force=None)
    res = node._record_q_dance(Trigger.Request(), Trigger.Response())
    assert res.success, res.message
    assert node.controller is not None
    lower = node.controller.position_lower[3:]
    np.testing.assert_allclose(lower, np.array(ARM) - 0.1, atol=1e-12)
    res = node._release_q_dance(Trigger.Request(), Trigger.Response())
    assert res.success and node.controller.config.joint_ranges == ()
    # Shutdown sends a zero command.
    assert harness.run(lambda: nonzero(harness.left), force=np.array([0.0, 0.0, 12.0]))
    harness.executor.remove_node(node)
    count = len(harness.left)
    node.destroy_node()
    harness.node_destroyed = True
    deadline = time.monotonic() + WAIT_S
    # Destroyed: nothing non-zero can follow, so the last message must end up zero.
    while (len(harness.left) <= count or nonzero(harness.left)) and time.monotonic() < deadline:
        harness.executor.spin_once(timeout_sec=0.01)
    assert len(harness.left) > count and not nonzero(harness.left)
    assert harness.twists[-1].linear.x == 0.0 and harness.twists[-1].angular.z == 0.0


class SimClockHarness(Harness):
    """The node under ``use_sim_time``; the peer owns /clock (the lock-step simulator's role)."""

    def __init__(self, context: object) -> None:
        from rosgraph_msgs.msg import Clock

        node = WholeBodyControllerNode(
            kinematics=FakeKinematics(), context=context,
            parameter_overrides=[Parameter("use_sim_time", value=True)],
        )
        super().__init__(context, node)
        self.clock_pub = self.peer.create_publisher(Clock, "/clock", 10)
        self.clock_type = Clock
        self.sim_ns = 1_000_000_000

    def cycles(self) -> int:
        """Control cycles the node has run."""
        return self.node.good_cycles + self.node.zero_cycles

    def advance(self, seconds: float, inputs: bool, force: np.ndarray | None = None) -> None:
        """Advance sim time in 10 ms steps (waiting until the node sees each), publishing the
        inputs at every step if asked (waiting until they arrived), and waiting for the step's
        control cycle (the 100 Hz timer on sim time is due once per step)."""
        node = self.node
        for _ in range(round(seconds / 0.01)):
            cycles = self.cycles()
            self.sim_ns += 10_000_000
            msg = self.clock_type()
            msg.clock.sec, msg.clock.nanosec = divmod(self.sim_ns, 1_000_000_000)
            self.clock_pub.publish(msg)
            now = self.sim_ns * 1e-9

            def clock_seen(now: float = now) -> bool:
                return abs(node.now_s() - now) < 1e-9

            def inputs_seen(now: float = now) -> bool:
                fresh = node.freshness
                return fresh.odom_time == now and min(fresh.contact_time.values()) == now

            assert spin_until(self.executor, clock_seen, WAIT_S)
            if inputs:
                self.publish_inputs(force)
                assert spin_until(self.executor, inputs_seen, WAIT_S)
            assert spin_until(self.executor, lambda cycles=cycles: self.cycles() > cycles, WAIT_S)
            assert self.cycles() == cycles + 1

    def spin(self, wall_seconds: float) -> None:
        spin_until(self.executor, lambda: False, wall_seconds)


@pytest.mark.ros
def test_staleness_follows_sim_time_not_the_wall_clock(ros_context: object) -> None:
    h = SimClockHarness(ros_context)
    try:
        node = h.node
        force = np.array([0.0, 0.0, 12.0])
        assert node.controller is not None
        resets: list[float] = []
        reset = node.controller.reset

        def counted_reset() -> None:
            resets.append(node.now_s())
            reset()

        node.controller.reset = counted_reset  # type: ignore[method-assign]
        # Sim time advancing with fresh inputs → commands.
        h.advance(0.5, inputs=True, force=force)
        assert node.good_cycles > 5 and nonzero(h.left)
        assert abs(node.now_s() - h.sim_ns * 1e-9) < 1e-9, "node clock follows /clock"
        # The host stalls for 3 contact timeouts of wall time while sim time stands still: no
        # input is stale in sim time, so no zero cycle (the wall clock must not matter).
        zero_before = node.zero_cycles
        h.spin(0.3)
        assert node.freshness.stale_reason(node.now_s()) is None
        h.advance(0.02, inputs=True, force=force)
        assert node.zero_cycles == zero_before and nonzero(h.left)
        # Inputs stop while sim time runs on: zero once sim time passes the timeout (0.1 s),
        # i.e. within one control period (10 ms) of it.
        good_before = node.good_cycles
        h.advance(0.08, inputs=False)
        assert node.zero_cycles == zero_before, "still within the timeout in sim time"
        h.advance(0.04, inputs=False)
        assert node.zero_cycles > zero_before and not nonzero(h.left)
        assert h.twists[-1].linear.x == 0.0 and h.twists[-1].angular.z == 0.0
        assert node.good_cycles - good_before <= 10
        # The tasks were reset once, when the inputs went stale (not at start-up, not per cycle).
        h.advance(0.05, inputs=False)
        assert len(resets) == 1 and node.zero_cycles > zero_before + 3
        # Inputs come back → commands resume.
        h.advance(0.2, inputs=True, force=force)
        assert nonzero(h.left)
    finally:
        h.close()
