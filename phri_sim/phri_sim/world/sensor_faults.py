"""Sensor faults for rehearsing failures in the simulator (pure, no rclpy).

A fault changes what the simulated *sensors* report, where a real fault would enter: the taxel
arrays the skin publishes and the joint states the arms publish. The robot, the person and the
physics are untouched, and nothing downstream (contact estimation, controller) is told. The
bridge passes every outgoing taxel frame through :meth:`SensorFaults.taxels` and every joint state
through :meth:`SensorFaults.joints` (``docs/phri_sim.md``, "Fault injection").

Kinds (:data:`FAULT_KINDS`), all from the fault time t_f [s] of sim time on:

* ``skin_blind``: every taxel of every patch reads 0 N (a cut cable, a dead board) — persistent;
* ``skin_stuck``: every patch repeats its last frame before t_f (a frozen driver) — persistent;
* ``force_spike``: one taxel reads :data:`SPIKE_FORCE` for one frame: the most loaded taxel of the
  first frame at or after t_f in which the patch is touched (a taxel > 0 N; with no
  ``patch`` given, any patch) — transient;
* ``joint_jump``: one joint position (:data:`JUMP_JOINT`) reads :data:`JUMP_POSITION` in the
  first joint state at or after t_f (a corrupted encoder word) — transient.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]

FAULT_KINDS: tuple[str, ...] = ("skin_blind", "skin_stuck", "force_spike", "joint_jump")
"""The fault kinds (module docstring)."""
DEFAULT_FAULT_TIME = 5.0
"""Default fault time t_f [s] of sim time."""
SPIKE_FORCE = 3.0e38
"""Force of the spiking taxel [N]: close to the largest float32 (3.4e38), the worst finite value
the taxel wire format can carry."""
JUMP_JOINT = "left_elbow_joint"
"""The joint whose reading jumps."""
JUMP_POSITION = 10.0
"""The jumped reading [rad]: far outside the UR16e elbow's ±π."""


@dataclass(frozen=True)
class FaultSpec:
    """One fault to inject.

    Attributes:
        kind: one of :data:`FAULT_KINDS`.
        time: fault time t_f [s] of sim time (≥ 0).
        patch: ``force_spike`` only: the patch to spike ('' = the first touched patch).
        joint: ``joint_jump`` only: the joint whose reading jumps.
        value: the spiked force [N] / the jumped position [rad]; NaN = the kind's default
            (:data:`SPIKE_FORCE`, :data:`JUMP_POSITION`).
    """

    kind: str
    time: float = DEFAULT_FAULT_TIME
    patch: str = ""
    joint: str = JUMP_JOINT
    value: float = math.nan

    def __post_init__(self) -> None:
        if self.kind not in FAULT_KINDS:
            raise ValueError(f"fault {self.kind!r} refused: allowed {', '.join(FAULT_KINDS)}")
        if not (math.isfinite(self.time) and self.time >= 0.0):
            raise ValueError(f"fault_time {self.time} refused: allowed [0, inf) s")

    @property
    def transient(self) -> bool:
        """True for the one-frame / one-message faults (the stack should recover)."""
        return self.kind in ("force_spike", "joint_jump")

    @property
    def magnitude(self) -> float:
        """The spiked force [N] or jumped position [rad] (the default when ``value`` is NaN)."""
        if not math.isnan(self.value):
            return self.value
        return SPIKE_FORCE if self.kind == "force_spike" else JUMP_POSITION


class SensorFaults:
    """Applies a :class:`FaultSpec` (or nothing) to the sensor stream (module docstring).

    Args:
        spec: the fault; ``None`` = sensors as they are.
        joint_names: the names of the joint-state positions, in message order.

    Attributes:
        changed: per channel (patch name, or ``joint_states``) the sim time [s] of the last
            frame / message the fault changed.
        changes: how many frames / messages the fault changed.
        first_change: sim time [s] of the first one (``None`` = none yet).
    """

    def __init__(self, spec: FaultSpec | None, joint_names: tuple[str, ...]) -> None:
        self.spec = spec
        self.changed: dict[str, float] = {}
        self.changes = 0
        self.first_change: float | None = None
        self._joint = -1
        if spec is not None and spec.kind == "joint_jump":
            if spec.joint not in joint_names:
                raise ValueError(f"fault joint {spec.joint!r} refused: allowed "
                                 f"{', '.join(joint_names)}")
            self._joint = joint_names.index(spec.joint)
        self._last: dict[str, FloatArray] = {}
        self._done = False

    def _active(self, t: float, kind: str) -> bool:
        spec = self.spec
        return spec is not None and spec.kind == kind and t >= spec.time - 1e-9

    def taxels(self, patch: str, forces: FloatArray, t: float) -> FloatArray:
        """The taxel forces [N] patch ``patch`` reports at sim time ``t`` [s] for the true
        reading ``forces`` (returned unchanged when no skin fault acts; never modified)."""
        if self._active(t, "skin_blind"):
            self._mark(patch, t)
            return np.zeros_like(forces)
        if self.spec is not None and self.spec.kind == "skin_stuck":
            if t < self.spec.time - 1e-9:
                self._last[patch] = forces.copy()
                return forces
            self._mark(patch, t)
            return self._last.setdefault(patch, forces.copy()).copy()
        if self._active(t, "force_spike") and not self._done and forces.size and (
            self.spec is not None and (self.spec.patch in ("", patch))
            and bool(np.any(forces > 0.0))
        ):
            out = forces.copy()
            out[int(np.argmax(forces))] = self.spec.magnitude
            self._done = True
            self._mark(patch, t)
            return out
        return forces

    def joints(self, q: FloatArray, t: float) -> FloatArray:
        """The joint positions [rad] a joint state sent at sim time ``t`` [s] reports for the true
        ``q`` (returned unchanged unless the jump falls on this message; never modified)."""
        if self._active(t, "joint_jump") and not self._done and self.spec is not None:
            out = np.array(q, dtype=np.float64)
            out[self._joint] = self.spec.magnitude
            self._done = True
            self._mark("joint_states", t)
            return out
        return q

    def changed_at(self, t: float) -> set[str]:
        """The channels whose frame / message at sim time ``t`` [s] the fault changed."""
        return {channel for channel, when in self.changed.items() if when == t}

    def _mark(self, channel: str, t: float) -> None:
        self.changed[channel] = t
        self.changes += 1
        if self.first_change is None:
            self.first_change = t
