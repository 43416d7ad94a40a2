"""Base guard: limits keep the direction, NaN and staleness give zero; the node end to end."""

from __future__ import annotations

import math
import time

import pytest
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


@pytest.mark.ros
@pytest.mark.parametrize("stamped", [False, True])
def test_node_limits_and_stops_on_stale(ros_context: object, stamped: bool) -> None:
    guard = BaseGuardNode(context=ros_context, parameter_overrides=[
        Parameter("max_linear_x", value=0.1), Parameter("command_timeout", value=0.1),
        Parameter("output_stamped", value=stamped)])
    peer = Node("peer", context=ros_context)
    pub = peer.create_publisher(Twist, "/cmd_vel", 10)
    received: list[tuple[float, float, float, float]] = []

    def on_out(msg: Twist | TwistStamped) -> None:
        t = msg.twist if isinstance(msg, TwistStamped) else msg
        received.append((time.monotonic(), t.linear.x, t.linear.y, t.angular.z))

    peer.create_subscription(TwistStamped if stamped else Twist, "base/cmd_vel", on_out, 50)
    executor = SingleThreadedExecutor(context=ros_context)  # type: ignore[arg-type]
    executor.add_node(guard)
    executor.add_node(peer)
    try:
        assert spin_until(executor, lambda: bool(received), 5.0)  # zeros while nothing came
        assert received[-1][1:] == (0.0, 0.0, 0.0)
        received.clear()
        end = time.monotonic() + 0.5
        while time.monotonic() < end:
            pub.publish(planar_twist(0.4, 0.0, 0.0))
            executor.spin_once(timeout_sec=0.01)
        moving = [r for r in received if r[1] != 0.0]
        assert moving and all(r[1] == pytest.approx(0.1) for r in moving)
        t_last = time.monotonic()
        received.clear()
        assert spin_until(executor, lambda: any(r[1] == 0.0 for r in received), 2.0)
        first_zero = next(r for r in received if r[1] == 0.0)
        assert first_zero[0] - t_last < 1.0  # timeout 0.1 s, loose bound for a loaded machine
        # NaN keeps the node alive and answers zero
        pub.publish(planar_twist(math.nan, 0.0, 0.0))
        received.clear()
        assert spin_until(executor, lambda: bool(received), 2.0)
        assert received[-1][1] == 0.0
    finally:
        guard.destroy_node()
        peer.destroy_node()
        executor.shutdown()


def test_config_refusal_names_the_setting_value_and_range() -> None:
    with pytest.raises(ValueError, match=r"max_angular_z refused value -0.5: allowed \[0, inf\)"):
        BaseGuardConfig(max_angular_z=-0.5)
