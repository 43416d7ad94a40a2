"""The simulated robot's command input: latest command per channel, staleness, speed limits (pure).

Channels: ``base`` (3: body twist v_x [m/s], v_y [m/s], ω_z [rad/s]) and ``left``/``right`` (6 arm
joint velocities [rad/s], UR order). A channel that has not been commanded within ``timeout`` [s]
of sim time reads as zero, so a lost command stream stops the robot (design §8); a malformed
command is refused and zeroes its channel. What the servos follow (:meth:`CommandWatchdog.applied`)
is the three channels in that order, clipped to the robot's speed limits as the real drivers do.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]

COMMAND_SIZES: dict[str, int] = {"base": 3, "left": 6, "right": 6}
"""Channel → number of values, in the order of :meth:`CommandWatchdog.applied`."""
COMMAND_SIZE = sum(COMMAND_SIZES.values())
"""Length of the applied command (body twist then the two arms)."""


class CommandError(ValueError):
    """A command is malformed (wrong size, NaN/Inf)."""


class CommandWatchdog:
    """Latest command per channel with a staleness timeout in simulation time (module docstring).

    Args:
        timeout: staleness timeout [s] of sim time (> 0).
        limits: speed limit per applied value (15, > 0) [m/s, rad/s]; ``None`` = no clipping.
    """

    def __init__(self, timeout: float, limits: FloatArray | None = None) -> None:
        if not (math.isfinite(timeout) and timeout > 0.0):
            raise ValueError(f"command timeout must be > 0 [s], got {timeout}")
        self.timeout = timeout
        self._limits = np.full(COMMAND_SIZE, math.inf) if limits is None else np.asarray(
            limits, dtype=np.float64)
        if self._limits.shape != (COMMAND_SIZE,) or not np.all(self._limits > 0.0):
            raise ValueError(f"command limits must be {COMMAND_SIZE} values > 0, got {limits}")
        self._values = {k: np.zeros(n) for k, n in COMMAND_SIZES.items()}
        self._times = dict.fromkeys(COMMAND_SIZES, -math.inf)
        self._version = 0  # incremented by every set (accepted or refused)
        self._applied = np.zeros(COMMAND_SIZE)
        self._applied_version = -1
        self._applied_until = -math.inf

    def set(self, channel: str, values: FloatArray, t: float) -> None:
        """Store a command received at sim time ``t`` [s].

        Raises:
            CommandError: unknown channel, wrong size or a non-finite value (the channel is
                zeroed: a bad command stops that part of the robot).
        """
        if channel not in COMMAND_SIZES:
            raise CommandError(f"unknown command channel {channel!r}")
        arr = np.asarray(values, dtype=np.float64).reshape(-1)
        n = COMMAND_SIZES[channel]
        self._version += 1
        if arr.shape != (n,) or not np.all(np.isfinite(arr)):
            self._values[channel] = np.zeros(n)
            self._times[channel] = -math.inf
            raise CommandError(
                f"{channel} command must be {n} finite numbers, got {arr.tolist()}"
            )
        self._values[channel] = arr.copy()
        self._times[channel] = t

    def current(self, channel: str, t: float) -> FloatArray:
        """The command to apply at sim time ``t`` (zero when stale or never received), unclipped."""
        if t - self._times[channel] > self.timeout:
            return np.zeros(COMMAND_SIZES[channel])
        return self._values[channel]

    def next_change(self, t: float) -> float:
        """Sim time [s] after which a channel that is fresh at ``t`` goes stale (inf if none
        will): until then, and without a new :meth:`set`, :meth:`current` keeps its value."""
        ends = [s + self.timeout for s in self._times.values() if t - s <= self.timeout]
        return min(ends) if ends else math.inf

    def received(self, t: float) -> FloatArray:
        """The 15 commanded velocities in force at sim time ``t``: body twist then the arms,
        after the timeout, before clipping (a new array)."""
        return np.concatenate([self.current(k, t) for k in COMMAND_SIZES])

    def applied(self, t: float) -> FloatArray:
        """The 15 velocities the servos follow at sim time ``t``: body twist then the arms, after
        the timeout and clipped to the limits. Recomputed only when a command arrives or one goes
        stale (a hair early at the staleness instant, where t − t_set vs timeout is decided by
        rounding); the returned array must not be modified."""
        if self._version != self._applied_version or t >= self._applied_until - 1e-9:
            u = self.received(t)
            self._applied = np.asarray(np.clip(u, -self._limits, self._limits))
            self._applied_version = self._version
            self._applied_until = self.next_change(t)
        return self._applied
