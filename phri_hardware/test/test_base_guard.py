"""Base guard: limits keep the direction, NaN and staleness give zero; the node end to end."""

from __future__ import annotations

import math

import pytest
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from geometry_msgs.msg import Twist, TwistStamped
from hypothesis import given, settings
from hypothesis import strategies as st
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter

from phri_common.testing import spin_until
from phri_hardware.base_guard import ZERO, BaseGuard, BaseGuardConfig, limit_twist
from phri_hardware.base_guard_node import BaseGuardNode
from phri_hardware.messages import planar_twist

CONFIG = BaseGuardConfig(max_linear_x=0.15, max_linear_y=0.1, max_planar_speed=0.12,
                         max_angular_z=0.2, command_timeout=0.1)

finite = st.floats(-10.0, 10.0)


@settings(max_examples=300, deadline=None)
@given(finite, finite, finite)
def test_limited_twist_is_within_every_limit_and_keeps_direction(vx: float, vy: float,
                                                                 wz: float) -> None:
    (ox, oy, oz), factor = limit_twist((vx, vy, wz), CONFIG)
    eps = 1e-12
    assert abs(ox) <= CONFIG.max_linear_x + eps and abs(oy) <= CONFIG.max_linear_y + eps
    assert math.hypot(ox, oy) <= CONFIG.max_planar_speed + eps
    assert abs(oz) <= CONFIG.max_angular_z + eps
    # same direction: the output is a non-negative multiple of the input
    assert 0.0 <= factor <= 1.0
    assert ox == pytest.approx(factor * vx) and oy == pytest.approx(factor * vy)
    assert oz == pytest.approx(factor * wz)
    inside = (abs(vx) <= 0.15 and abs(vy) <= 0.1 and math.hypot(vx, vy) <= 0.12
              and abs(wz) <= 0.2)
    assert (factor == 1.0) == inside


def test_an_over_limit_diagonal_is_scaled_to_the_planar_limit() -> None:
    (ox, oy, oz), _ = limit_twist((0.3, 0.3, 0.0), CONFIG)
    assert ox == pytest.approx(oy)  # still 45°
    assert math.hypot(ox, oy) == pytest.approx(min(0.12, 0.1 * math.sqrt(2)))
    assert oz == 0.0


def test_nan_and_stale_give_zero() -> None:
    guard = BaseGuard(CONFIG)
    assert guard.check(0.0) == ZERO  # nothing received yet
    assert guard.command([0.1, 0.0, 0.0, 0.0, 0.0, 0.1], 1.0) == (0.1, 0.0, 0.1)
    assert guard.check(1.05) is None
    assert guard.check(1.11) == ZERO
    assert guard.command([math.nan, 0.0, 0.0, 0.0, 0.0, 0.0], 2.0) == ZERO
    assert guard.command([0.0, 0.0, 0.0, 0.0, math.inf, 0.0], 2.0) == ZERO
    assert guard.counters.refused == 2
    # a planar base ignores v_z, ω_x, ω_y
    assert guard.command([0.0, 0.05, 1.0, 1.0, 1.0, 0.0], 3.0) == (0.0, 0.05, 0.0)


WAIT_S = 60.0
"""Longest wait for something that must happen (a stalled machine); never a measured time."""


class FakeClock:
    """The node's monotonic clock [s], moved only by the test; counts the node's reads."""

    def __init__(self, now: float) -> None:
        self.now = now
        self.reads = 0

    def __call__(self) -> float:
        self.reads += 1
        return self.now


@pytest.mark.ros
@pytest.mark.parametrize("stamped", [False, True])
def test_node_limits_and_stops_on_stale(ros_context: object, stamped: bool) -> None:
    """On a fake node clock: zero while nothing came; a twist over the limit is passed scaled;
    the staleness checks while the clock reads 99 ms after it send nothing, the first check once
    it reads 101 ms (command_timeout 100 ms) sends zero; NaN is answered with zero, the node
    stays up and passes the next good twist."""
    clock = FakeClock(1000.0)
    guard = BaseGuardNode(clock=clock, context=ros_context, parameter_overrides=[
        Parameter("max_linear_x", value=0.1), Parameter("command_timeout", value=0.1),
        Parameter("output_stamped", value=stamped), Parameter("diagnostics_period", value=0.05)])
    peer = Node("peer", context=ros_context)
    pub = peer.create_publisher(Twist, "/cmd_vel", 10)
    received: list[tuple[float, float, float]] = []
    diagnostics: list[DiagnosticStatus] = []

    def on_out(msg: Twist | TwistStamped) -> None:
        t = msg.twist if isinstance(msg, TwistStamped) else msg
        received.append((t.linear.x, t.linear.y, t.angular.z))

    def value(status: DiagnosticStatus, key: str) -> str:
        return next(kv.value for kv in status.values if kv.key == key)

    peer.create_subscription(TwistStamped if stamped else Twist, "base/cmd_vel", on_out, 50)
    peer.create_subscription(DiagnosticArray, "/diagnostics",
                             lambda m: diagnostics.extend(m.status), 50)
    executor = SingleThreadedExecutor(context=ros_context)  # type: ignore[arg-type]
    executor.add_node(guard)
    executor.add_node(peer)
    try:
        assert spin_until(executor, lambda: bool(received), WAIT_S)  # zeros while nothing came
        assert received[-1] == (0.0, 0.0, 0.0)
        assert spin_until(executor, lambda: pub.get_subscription_count() > 0, WAIT_S)
        pub.publish(planar_twist(0.4, 0.0, 0.0))  # arrives at 1000.0 on the node's clock
        assert spin_until(executor, lambda: received[-1] != (0.0, 0.0, 0.0), WAIT_S)
        passed = len(received)
        assert received[-1] == pytest.approx((0.1, 0.0, 0.0))  # scaled into the limit
        assert spin_until(executor, lambda: bool(diagnostics)
                          and diagnostics[-1].message == "passing commands", WAIT_S)
        zeros = value(diagnostics[-1], "stale_zeros")  # sent while nothing had come
        # 99 ms later: ≥ 10 more reads of the clock (checks at 50 Hz, diagnostics at 20 Hz)
        # and 3 more reports: still fresh, no further stale zero counted, none received.
        clock.now, reads, reports = 1000.099, clock.reads, len(diagnostics)
        assert spin_until(executor, lambda: clock.reads >= reads + 10
                          and len(diagnostics) >= reports + 3, WAIT_S)
        assert all(s.message == "passing commands" and value(s, "stale_zeros") == zeros
                   for s in diagnostics[reports:])
        assert len(received) == passed
        # 101 ms: stale, and the next check sends zero.
        clock.now = 1000.101
        assert spin_until(executor, lambda: len(received) > passed, WAIT_S)
        assert received[passed] == (0.0, 0.0, 0.0)
        assert spin_until(executor, lambda: diagnostics[-1].message.startswith("command stale"),
                          WAIT_S)
        # NaN keeps the node alive and answers zero; the next good twist passes again.
        pub.publish(planar_twist(math.nan, 0.0, 0.0))
        assert spin_until(executor, lambda: value(diagnostics[-1], "refused") == "1", WAIT_S)
        assert received[-1] == (0.0, 0.0, 0.0)
        pub.publish(planar_twist(0.05, 0.0, 0.0))
        assert spin_until(executor, lambda: received[-1] == pytest.approx((0.05, 0.0, 0.0)),
                          WAIT_S)
    finally:
        guard.destroy_node()
        peer.destroy_node()
        executor.shutdown()


def test_config_refusal_names_the_setting_value_and_range() -> None:
    with pytest.raises(ValueError, match=r"max_angular_z refused value -0.5: allowed \[0, inf\)"):
        BaseGuardConfig(max_angular_z=-0.5)
