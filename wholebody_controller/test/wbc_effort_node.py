"""The controller node driven by hand with joint efforts (the tests of the guard against
unsensed contacts and of the skin-against-joints check share it): its clock, its commands and
the diagnostics statuses of one name recorded; one period at a time."""

from __future__ import annotations

import numpy as np
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

FloatArray = NDArray[np.float64]
ARM = [0.0, -0.3, 0.3, 3.14159, 0.0, 0.0, 0.0, 0.3, -0.3, 0.0, 0.0, 0.0]
"""The arms' joint positions [rad] (left, then right, UR order)."""
Q = np.array([0.0, 0.0, 0.0, *ARM])
CENTER = np.array([0.18, 0.0, 0.06])
"""Where the skin is touched on the left forearm, link frame [m]."""
LINK = "left_forearm_link"
PERIOD_NS = 10_000_000


def touch(force: float, stamp: int) -> ContactState:
    """The skin's reading: ``force`` [N] pressing the left forearm at CENTER."""
    return ContactState(LINK, stamp, True, CENTER, np.array([0.0, -force, 0.0]), np.zeros(3),
                        CENTER - 0.02, CENTER + 0.02, 16)


class EffortNode(WholeBodyControllerNode):
    """The node with its commands and the diagnostics statuses named ``*status`` recorded."""

    def __init__(self, context: object, status: str, **params: object) -> None:
        self.now_ns = 1_000_000_000
        self.commands: list[FloatArray] = []
        self.statuses: list[DiagnosticStatus] = []
        self._status = status
        overrides = [Parameter("control_loop", value="timer"),
                     Parameter("velocity_limit", value=0.15),
                     *(Parameter(k, value=v) for k, v in params.items())]
        super().__init__(context=context, clock_ns=lambda: self.now_ns,
                         parameter_overrides=overrides)
        self.dynamics = ArmDynamics()
        self.gravity = self.dynamics.needed(Q, np.zeros(15), np.zeros(15))
        self.diag_pub.publish = self._record  # type: ignore[method-assign]

    def _record(self, msg: object) -> None:
        self.statuses += [s for s in msg.status  # type: ignore[attr-defined]
                          if s.name.endswith(self._status)]

    def publish_command(self, command: FloatArray) -> None:
        self.commands.append(np.array(command))
        super().publish_command(command)

    def felt(self, force: float) -> FloatArray:
        """External torques (15, q order) of a true ``force`` [N] at the skin's CENTER."""
        return self.dynamics.skin_torques(Q, {LINK: touch(force, 0)})

    def period(self, skin_force: float | None, external: FloatArray,
               efforts: bool = True) -> FloatArray:
        """One period: the skin reports ``skin_force`` [N] on the left forearm (None: no contact
        anywhere), joint states with the efforts of external torques ``external`` [N·m] (15, q
        order; ``efforts=False``: none sent), odometry; the command."""
        self.now_ns += PERIOD_NS
        for link in self.links:
            state = ContactState.no_contact(link, self.now_ns)
            if link == LINK and skin_force is not None:
                state = touch(skin_force, self.now_ns)
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
