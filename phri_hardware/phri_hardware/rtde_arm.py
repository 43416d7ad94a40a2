"""ur_rtde behind :class:`~phri_hardware.ur_arm.ArmInterface` (the module boundary to the robot).

Only this module imports ``rtde_control`` / ``rtde_receive``, and only inside
:meth:`UrRtdeArm.connect`, which runs in the bridge's worker process
(:mod:`phri_hardware.arm_worker`): the constructors can block for minutes holding the GIL.

The receive interface asks only for the outputs the bridge reads (:data:`RECEIVE_VARIABLES`),
which every e-Series and CB3 controller serves. ``receive_only`` (the bridge's monitor mode)
opens no control interface at all: no dashboard connection, no control script, no command.

Joint efforts (``/joint_states`` ``effort``, docs/interfaces.md "Joint efforts"): the torque each
drive applies, gravity included. A UR reports it as RTDE ``actual_current_as_torque`` from
PolyScope 5.23 / 10.11 on (what ur_robot_driver publishes with ``use_currents_as_efforts:
false``), but ur_rtde 1.6.5's Python binding has no getter for it (its C++ library has
``getActualCurrentAsTorque``). What the binding reads on every e-Series: the measured currents
``actual_current`` [A] and the controller's target currents and target moments
(``target_current`` [A], ``target_moment`` [N·m], the model's torques for the commanded motion,
gravity included). :class:`CurrentTorque` turns them into a torque: τ_j = i_actual,j · k_j with
k_j = τ_target,j / i_target,j, the controller's own torque per ampere, taken whenever
|i_target,j| ≥ :data:`MIN_TARGET_CURRENT` and kept (nan until the first). An estimate: check it
against ``actual_current_as_torque`` (or ur_robot_driver) on the robot before relying on it.
"""

from __future__ import annotations

import contextlib
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from phri_hardware.ur_arm import DISCONNECTED_STATE, ArmState

RECEIVE_VARIABLES = ["actual_q", "actual_qd", "robot_mode", "safety_mode", "safety_status_bits",
                     "speed_scaling", "target_speed_fraction", "runtime_state",
                     "actual_current", "target_current", "target_moment"]
"""RTDE outputs the bridge reads (``isProtectiveStopped``/``isEmergencyStopped`` use the
safety status bits; ``getSpeedScalingCombined`` the speed scaling, the pendant's speed slider
and the runtime state; the efforts the currents and target moments)."""

MIN_TARGET_CURRENT = 0.1
"""Least |target current| [A] from which a joint's torque per ampere is taken."""


class CurrentTorque:
    """Joint torques from RTDE's currents (module docstring): τ = i_actual · k, k = the last
    τ_target / i_target with |i_target| ≥ :data:`MIN_TARGET_CURRENT` (nan before)."""

    def __init__(self) -> None:
        self.per_ampere = [math.nan] * 6

    def torques(self, actual: Sequence[float], target: Sequence[float],
                moment: Sequence[float]) -> tuple[float, ...]:
        """The drives' torques [N·m] from actual and target currents [A] and target moments
        [N·m] (6 each; anything else: nan)."""
        if not all(isinstance(v, Sequence) and len(v) == 6 for v in (actual, target, moment)):
            return (math.nan,) * 6
        for j in range(6):
            if abs(target[j]) >= MIN_TARGET_CURRENT and math.isfinite(moment[j]):
                self.per_ampere[j] = moment[j] / target[j]
        return tuple(float(a) * k for a, k in zip(actual, self.per_ampere, strict=True))


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
        self._torque = CurrentTorque()

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
                effort=self._torque.torques(self._receive.getActualCurrent(),
                                            self._receive.getTargetCurrent(),
                                            self._receive.getTargetMoment()),
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


__all__ = ["MIN_TARGET_CURRENT", "RECEIVE_VARIABLES", "CurrentTorque", "UrRtdeArm",
           "UrRtdeArmFactory"]
