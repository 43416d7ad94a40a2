"""ROS 2 node: velocity limit and stale-command stop between ``/cmd_vel`` and the base driver.

* subscribes ``/cmd_vel`` (geometry_msgs/Twist, base frame; remap to read another topic);
* publishes ``base/cmd_vel`` (geometry_msgs/Twist, or geometry_msgs/TwistStamped with
  ``output_stamped`` — mecanum_drive_controller's ``~/reference`` type); remap it to the driver's
  input;
* publishes ``/diagnostics``.

``/odom`` is not touched: the base driver publishes it (mecanum_drive_controller: remap its
``~/odometry`` to ``/odom``); see docs/hardware.md. The rules are
:class:`phri_hardware.base_guard.BaseGuard`'s.
"""

from __future__ import annotations

import contextlib
import sys
import time
from collections.abc import Callable
from typing import Any

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import Twist, TwistStamped
from rclpy.node import Node

from phri_common import paper
from phri_common.params import ParamSpec, ParamValue
from phri_common.ros_main import run_nodes
from phri_common.ros_params import declare_parameters
from phri_hardware.base_guard import BaseGuard, BaseGuardConfig, PlanarTwist
from phri_hardware.messages import planar_twist, planar_twist_stamped, twist_to_tuple

PARAMS: list[ParamSpec] = [
    ParamSpec("max_linear_x", paper.VELOCITY_LIMIT, "largest forward speed |v_x| (Table II: 0.15)",
              unit="m/s", low=0.0, high=3.0),
    ParamSpec("max_linear_y", paper.VELOCITY_LIMIT, "largest sideways speed |v_y|", unit="m/s",
              low=0.0, high=3.0),
    ParamSpec("max_planar_speed", 0.2, "largest planar speed ‖(v_x, v_y)‖", unit="m/s",
              low=0.0, high=3.0),
    ParamSpec("max_angular_z", paper.VELOCITY_LIMIT, "largest turn rate |ω_z|", unit="rad/s",
              low=0.0, high=6.0),
    ParamSpec("command_timeout", 0.1, "no twist for this long → zero", unit="s", low=0.005,
              high=5.0),
    ParamSpec("check_rate_hz", 50.0, "rate of the staleness check (zero is sent at this rate "
              "while stale)", unit="Hz", low=1.0, high=1000.0, read_only=True),
    ParamSpec("output_stamped", False, "publish geometry_msgs/TwistStamped instead of Twist "
              "(mecanum_drive_controller's reference)", read_only=True),
    ParamSpec("output_frame_id", "base_link", "header.frame_id of a stamped output",
              read_only=True),
    ParamSpec("diagnostics_period", 1.0, "period of /diagnostics", unit="s", low=0.05,
              high=60.0, read_only=True),
]


def guard_config_from_values(values: dict[str, ParamValue]) -> BaseGuardConfig:
    """Parameter values → guard configuration."""
    return BaseGuardConfig(
        max_linear_x=float(values["max_linear_x"]),
        max_linear_y=float(values["max_linear_y"]),
        max_planar_speed=float(values["max_planar_speed"]),
        max_angular_z=float(values["max_angular_z"]),
        command_timeout=float(values["command_timeout"]),
    )


class BaseGuardNode(Node):
    """Limits and staleness stop for the mobile base's velocity command.

    Args:
        clock: monotonic clock [s] that stamps arriving twists and judges their age (tests
            replace it).
        kwargs: passed to ``rclpy.node.Node`` (``context``, ``parameter_overrides`` …).
    """

    def __init__(self, clock: Callable[[], float] = time.monotonic, **kwargs: Any) -> None:
        super().__init__("base_guard", **kwargs)
        self._mono = clock
        self._values = declare_parameters(self, PARAMS, on_change=self._on_change)
        self._guard = BaseGuard(guard_config_from_values(self._values))
        self._stamped = bool(self._values["output_stamped"])
        self._frame_id = str(self._values["output_frame_id"])
        msg_type = TwistStamped if self._stamped else Twist
        self._pub = self.create_publisher(msg_type, "base/cmd_vel", 10)
        self._diag_pub = self.create_publisher(DiagnosticArray, "/diagnostics", 10)
        self._sub = self.create_subscription(Twist, "/cmd_vel", self._on_twist, 10)
        self._check_timer = self.create_timer(
            1.0 / float(self._values["check_rate_hz"]), self._check
        )
        self._diag_timer = self.create_timer(
            float(self._values["diagnostics_period"]), self._publish_diagnostics
        )

    def _on_change(self, values: dict[str, ParamValue]) -> None:
        self._guard.config = guard_config_from_values(values)

    def _send(self, twist: PlanarTwist) -> None:
        if self._stamped:
            stamp = self.get_clock().now().to_msg()
            self._pub.publish(planar_twist_stamped(*twist, self._frame_id, stamp))
        else:
            self._pub.publish(planar_twist(*twist))

    def _on_twist(self, msg: Twist) -> None:
        refused_before = self._guard.counters.refused
        self._send(self._guard.command(twist_to_tuple(msg), self._mono()))
        if self._guard.counters.refused > refused_before:
            self.get_logger().warning(
                f"refused {self._guard.counters.last_refusal}; sent zero",
                throttle_duration_sec=1.0,
            )

    def _check(self) -> None:
        zero = self._guard.check(self._mono())
        if zero is not None:
            self._send(zero)

    def _publish_diagnostics(self) -> None:
        c = self._guard.counters
        stale = self._guard.stale(self._mono())
        level = DiagnosticStatus.WARN if stale or c.refused else DiagnosticStatus.OK
        status = DiagnosticStatus(
            level=level, name=f"{self.get_fully_qualified_name()}: base guard",
            hardware_id="base",
            message="command stale: sending zero" if stale else "passing commands",
            values=[KeyValue(key="received", value=str(c.received)),
                    KeyValue(key="refused", value=str(c.refused)),
                    KeyValue(key="limited", value=str(c.limited)),
                    KeyValue(key="stale_zeros", value=str(c.stale_zeros)),
                    KeyValue(key="last_refusal", value=c.last_refusal)],
        )
        msg = DiagnosticArray(status=[status])
        msg.header.stamp = self.get_clock().now().to_msg()
        self._diag_pub.publish(msg)

    def destroy_node(self) -> None:
        """Send zero to the base before going away."""
        # With the context already shut down, the driver's own timeout stops the base.
        with contextlib.suppress(Exception):
            self._send((0.0, 0.0, 0.0))
        super().destroy_node()


def main(args: list[str] | None = None) -> None:
    """Entry point ``base_guard_node``."""
    sys.exit(run_nodes(lambda: [BaseGuardNode()], "base_guard", args))


__all__ = ["PARAMS", "BaseGuardNode", "guard_config_from_values", "main"]
