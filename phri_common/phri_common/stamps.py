"""Conversions between ROS time stamps and integer nanoseconds (pure, no rclpy)."""

from __future__ import annotations

from builtin_interfaces.msg import Time

NS_PER_S = 1_000_000_000


def stamp_to_ns(stamp: Time) -> int:
    """ROS ``builtin_interfaces/Time`` → integer nanoseconds."""
    return int(stamp.sec) * NS_PER_S + int(stamp.nanosec)


def ns_to_stamp(ns: int) -> Time:
    """Integer nanoseconds (≥ 0) → ROS ``builtin_interfaces/Time``."""
    if ns < 0:
        raise ValueError(f"time stamp must be non-negative, got {ns} ns")
    sec, nanosec = divmod(int(ns), NS_PER_S)
    return Time(sec=sec, nanosec=nanosec)
