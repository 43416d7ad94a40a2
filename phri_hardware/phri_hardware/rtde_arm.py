"""ur_rtde behind :class:`~phri_hardware.ur_arm.ArmInterface` (the module boundary to the robot).

Only this module imports ``rtde_control`` / ``rtde_receive``, and only inside
:meth:`UrRtdeArm.connect`, which runs in the bridge's worker process
(:mod:`phri_hardware.arm_worker`): the constructors can block for minutes holding the GIL.
"""

from __future__ import annotations

import contextlib
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from phri_hardware.ur_arm import DISCONNECTED_STATE, ArmState


@dataclass(frozen=True)
class UrRtdeArmFactory:
    """Picklable factory: ``UrRtdeArmFactory("192.168.1.10")()`` → :class:`UrRtdeArm`.

    Attributes:
        host: robot IP address or host name.
        frequency: RTDE frequency [Hz] (-1 = the robot's default: 500 Hz on e-Series).
    """

    host: str
    frequency: float = -1.0

    def __call__(self) -> UrRtdeArm:
        return UrRtdeArm(self.host, self.frequency)


class UrRtdeArm:
    """One UR arm over ur_rtde (``RTDEReceiveInterface`` + ``RTDEControlInterface``)."""

    def __init__(self, host: str, frequency: float = -1.0) -> None:
        self.host = host
        self.frequency = frequency
        self._receive: Any = None
        self._control: Any = None

    def connect(self) -> None:
        """Open both RTDE interfaces (blocking; uploads ur_rtde's control script)."""
        import rtde_control
        import rtde_receive

        self._receive = rtde_receive.RTDEReceiveInterface(self.host, self.frequency)
        self._control = rtde_control.RTDEControlInterface(self.host, self.frequency)

    def read_state(self) -> ArmState:
        """Current state; any ur_rtde error reads as a lost connection."""
        if self._receive is None or self._control is None:
            return DISCONNECTED_STATE
        try:
            if not (self._receive.isConnected() and self._control.isConnected()):
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
                program_running=bool(self._control.isProgramRunning()),
                connected=True,
            )
        except RuntimeError:
            return DISCONNECTED_STATE

    def speed_j(self, qd: Sequence[float], acceleration: float, time: float) -> bool:
        return bool(self._control.speedJ(list(qd), acceleration, time))

    def speed_stop(self, deceleration: float) -> bool:
        return bool(self._control.speedStop(deceleration))

    def set_watchdog(self, min_frequency: float) -> bool:
        return bool(self._control.setWatchdog(min_frequency))

    def kick_watchdog(self) -> bool:
        return bool(self._control.kickWatchdog())

    def restart_program(self) -> bool:
        return bool(self._control.reuploadScript())

    def disconnect(self) -> None:
        if self._control is not None:
            with contextlib.suppress(RuntimeError):
                self._control.stopScript()  # ends ur_rtde's program: nothing keeps moving
        for iface in (self._control, self._receive):
            if iface is not None:
                with contextlib.suppress(RuntimeError):
                    iface.disconnect()
        self._control = self._receive = None


__all__ = ["UrRtdeArm", "UrRtdeArmFactory"]
