"""Sensor faults for rehearsing failures in the simulator (pure, no rclpy).

A fault changes what the simulated *sensors* report, where a real fault would enter: the taxel
arrays the skin publishes and the joint states the arms publish. The robot, the person and the
physics are untouched, and nothing downstream (contact estimation, controller) is told. The
bridge passes every outgoing taxel frame through :meth:`SensorFaults.taxels` and every joint state
through :meth:`SensorFaults.joints` (``docs/phri_sim.md``, "Fault injection").

Kinds (:data:`FAULT_KINDS`), all from the fault time t_f [s] of sim time on:

* ``skin_blind``: every taxel of every patch reads 0 N (a cut cable, a dead board) — persistent;
* ``skin_stuck``: every patch repeats its last frame before t_f (a frozen driver) — persistent;
* ``skin_frozen_noisy``: the patch repeats its last frame before t_f with fresh relative noise on
  every taxel, f_j·(1 + σ n_j), n_j ~ N(0, 1), σ = ``value`` (default :data:`FROZEN_NOISE`,
  0.5 %): a frozen driver behind a noisy analogue stage, which the bit-identical stuck check
  cannot see — persistent;
* ``skin_half_dead``: the first half of the patch's taxels (layout order) read 0 N (a dead
  connector, a torn trace: a dead region) — persistent;
* ``skin_gain``: every taxel of the patch reads ``value`` × its force (default
  :data:`GAIN_FACTOR`: a gain far off, a wrong calibration file) — persistent;
* ``force_spike``: one taxel reads :data:`SPIKE_FORCE` for one frame: the most loaded taxel of the
  first frame at or after t_f in which the patch is touched (a taxel > 0 N; with no
  ``patch`` given, any patch) — transient;
* ``joint_jump``: one joint position (:data:`JUMP_JOINT`) reads :data:`JUMP_POSITION` in the
  first joint state at or after t_f (a corrupted encoder word) — transient.

``skin_blind`` and ``skin_stuck`` act on every patch; the three newer skin faults on ``patch``
('' = every patch; ``phri sim --fault-patch left_forearm``). The noise of ``skin_frozen_noisy``
is drawn from a generator seeded by :data:`FROZEN_NOISE_SEED` and the patch name
(deterministic).
"""

from __future__ import annotations

import math
import zlib
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]

FAULT_KINDS: tuple[str, ...] = ("skin_blind", "skin_stuck", "force_spike", "joint_jump",
                                "skin_frozen_noisy", "skin_half_dead", "skin_gain")
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
FROZEN_NOISE = 0.005
"""Relative noise σ of ``skin_frozen_noisy`` [-] (0.5 % of each taxel's frozen force)."""
GAIN_FACTOR = 3.0
"""Default gain factor of ``skin_gain`` [-]."""
FROZEN_NOISE_SEED = 0x0F0E
"""Seed of the frozen-noisy fault's noise (with the patch name's CRC-32)."""
PATCH_FAULTS = ("skin_frozen_noisy", "skin_half_dead", "skin_gain")
"""The skin faults that act on ``FaultSpec.patch`` only ('' = every patch)."""
_DEFAULT_VALUES = {"force_spike": SPIKE_FORCE, "joint_jump": JUMP_POSITION,
                   "skin_frozen_noisy": FROZEN_NOISE, "skin_gain": GAIN_FACTOR}


@dataclass(frozen=True)
class FaultSpec:
    """One fault to inject.

    Attributes:
        kind: one of :data:`FAULT_KINDS`.
        time: fault time t_f [s] of sim time (≥ 0).
        patch: ``force_spike``: the patch to spike ('' = the first touched patch); the
            :data:`PATCH_FAULTS`: the faulty patch ('' = every patch).
        joint: ``joint_jump`` only: the joint whose reading jumps.
        value: the spiked force [N] / the jumped position [rad] / the frozen frame's relative
            noise [-] / the gain factor [-]; NaN = the kind's default (:data:`SPIKE_FORCE`,
            :data:`JUMP_POSITION`, :data:`FROZEN_NOISE`, :data:`GAIN_FACTOR`).
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
        if not math.isnan(self.value) and self.kind in ("skin_frozen_noisy", "skin_gain") and \
                not (math.isfinite(self.value) and 0.0 <= self.value <= 1000.0):
            raise ValueError(f"fault_value {self.value} refused for {self.kind}: allowed "
                             "[0, 1000]")

    @property
    def transient(self) -> bool:
        """True for the one-frame / one-message faults (the stack should recover)."""
        return self.kind in ("force_spike", "joint_jump")

    @property
    def magnitude(self) -> float:
        """The spiked force [N], jumped position [rad], relative noise or gain factor [-] (the
        kind's default when ``value`` is NaN; NaN for a kind without a value)."""
        if not math.isnan(self.value):
            return self.value
        return _DEFAULT_VALUES.get(self.kind, math.nan)

    def acts_on(self, patch: str) -> bool:
        """Whether a :data:`PATCH_FAULTS` fault acts on ``patch``."""
        return self.kind in PATCH_FAULTS and self.patch in ("", patch)


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
        self._rngs: dict[str, np.random.Generator] = {}

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
        spec = self.spec
        if spec is not None and spec.acts_on(patch):
            return self._patch_fault(spec, patch, forces, t)
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

    def _patch_fault(self, spec: FaultSpec, patch: str, forces: FloatArray,
                     t: float) -> FloatArray:
        """The :data:`PATCH_FAULTS` on ``patch``'s reading ``forces`` [N] at ``t`` [s]."""
        if spec.kind == "skin_frozen_noisy" and t < spec.time - 1e-9:
            self._last[patch] = forces.copy()
            return forces
        if t < spec.time - 1e-9:
            return forces
        self._mark(patch, t)
        if spec.kind == "skin_gain":
            return forces * spec.magnitude
        if spec.kind == "skin_half_dead":
            out = forces.copy()
            out[: forces.size // 2] = 0.0
            return out
        frozen = self._last.setdefault(patch, forces.copy())
        rng = self._rngs.get(patch)
        if rng is None:
            rng = self._rngs[patch] = np.random.default_rng(
                [FROZEN_NOISE_SEED, zlib.crc32(patch.encode())])
        noisy = frozen * (1.0 + spec.magnitude * rng.standard_normal(frozen.size))
        return np.maximum(noisy, 0.0)

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
