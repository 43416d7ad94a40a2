"""ur_rtde behind :class:`~phri_hardware.ur_arm.ArmInterface` (the module boundary to the robot).

Only this module imports ``rtde_control`` / ``rtde_receive``, and only inside
:meth:`UrRtdeArm.connect`, which runs in the bridge's worker process
(:mod:`phri_hardware.arm_worker`): the constructors can block for minutes holding the GIL.

The receive interface asks only for the outputs the bridge reads (:data:`RECEIVE_VARIABLES`),
which every e-Series and CB3 controller serves. ``receive_only`` (the bridge's monitor mode)
opens no control interface at all: no dashboard connection, no control script, no command.
"""

from __future__ import annotations

import contextlib
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from phri_hardware.ur_arm import DISCONNECTED_STATE, ArmState

RECEIVE_VARIABLES = ["actual_q", "actual_qd", "robot_mode", "safety_mode", "safety_status_bits",
                     "speed_scaling", "target_speed_fraction", "runtime_state"]
"""RTDE outputs the bridge reads (``isProtectiveStopped``/``isEmergencyStopped`` use the
safety status bits; ``getSpeedScalingCombined`` the speed scaling, the pendant's speed slider
and the runtime state)."""


@dataclass(frozen=True)
class UrRtdeArmFactory:
    """Picklable factory: ``UrRtdeArmFactory("192.168.1.10")()`` → :class:`UrRtdeArm`.

    Attributes:
        host: robot IP address or host name.
        frequency: RTDE frequency [Hz] (-1 = the robot's default: 500 Hz on e-Series).
        receive_only: open only RTDE receive (monitor mode; no control interface).
    """

    host: str
    frequency: float = -1.0
    receive_only: bool = False

    def __call__(self) -> UrRtdeArm:
        return UrRtdeArm(self.host, self.frequency, self.receive_only)


class UrRtdeArm:
    """One UR arm over ur_rtde (``RTDEReceiveInterface`` [+ ``RTDEControlInterface``])."""

    def __init__(self, host: str, frequency: float = -1.0, receive_only: bool = False) -> None:
        self.host = host
        self.frequency = frequency
        self.receive_only = receive_only
        self._receive: Any = None
        self._control: Any = None

    def connect(self) -> None:
        """Open RTDE receive, then (unless receive-only) RTDE control, which connects to the
        dashboard server and uploads ur_rtde's control script. Blocking."""
        import rtde_receive

        self._receive = rtde_receive.RTDEReceiveInterface(
            self.host, self.frequency, RECEIVE_VARIABLES
        )
        if not self.receive_only:
            import rtde_control

            self._control = rtde_control.RTDEControlInterface(self.host, self.frequency)

    def _connected(self) -> bool:
        if self._receive is None or not self._receive.isConnected():
            return False
        if self.receive_only:
            return True
        return self._control is not None and bool(self._control.isConnected())

    def read_state(self) -> ArmState:
        """Current state; any ur_rtde error reads as a lost connection."""
        try:
            if not self._connected():
                return DISCONNECTED_STATE
            q = tuple(float(x) for x in self._receive.getActualQ())
            qd = tuple(float(x) for x in self._receive.getActualQd())
            return ArmState(
                q=q if len(q) == 6 else (math.nan,) * 6,
                qd=qd if len(qd) == 6 else (math.nan,) * 6,
                robot_mode=int(self._receive.getRobotMode()),
                safety_mode=int(self._receive.getSafetyMode()),
                protective_stopped=bool(self._receive.isProtectiveStopped()),
                emergency_stopped=bool(self._receive.isEmergencyStopped()),
                program_running=(
                    not self.receive_only and bool(self._control.isProgramRunning())
                ),
                connected=True,
                speed_scaling=float(self._receive.getSpeedScalingCombined()),
            )
        except RuntimeError:
            return DISCONNECTED_STATE

    def speed_j(self, qd: Sequence[float], acceleration: float, time: float) -> bool:
        return self._control is not None and bool(
            self._control.speedJ(list(qd), acceleration, time)
        )

    def speed_stop(self, deceleration: float) -> bool:
        return self._control is not None and bool(self._control.speedStop(deceleration))

    def set_watchdog(self, min_frequency: float) -> bool:
        return self._control is not None and bool(self._control.setWatchdog(min_frequency))

    def kick_watchdog(self) -> bool:
        return self._control is not None and bool(self._control.kickWatchdog())

    def restart_program(self) -> bool:
        return self._control is not None and bool(self._control.reuploadScript())

    def disconnect(self) -> None:
        if self._control is not None:
            with contextlib.suppress(RuntimeError):
                self._control.stopScript()  # ends ur_rtde's program: nothing keeps moving
        for iface in (self._control, self._receive):
            if iface is not None:
                with contextlib.suppress(RuntimeError):
                    iface.disconnect()
        self._control = self._receive = None


__all__ = ["RECEIVE_VARIABLES", "UrRtdeArm", "UrRtdeArmFactory"]
