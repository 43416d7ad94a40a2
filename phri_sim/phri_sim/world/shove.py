"""A shove: the partner pushes the waist into the robot with a given force for a given time
(pure, deterministic).

``phri sim --shove 250N@20s+3s`` (bridge parameter ``shove``): from t₀ = 20 s for 3 s a
horizontal force acts on the person's torso (``person_torso``, whose waist the left forearm
holds in the waltz) towards the robot. Its direction n̂ is fixed at t₀: the horizontal part of
the true contact force on :data:`SHOVE_LINK` (world frame), i.e. the way the waist already
presses the forearm; with no contact at t₀, from the torso towards that link's frame.

Two kinds (:data:`SHOVE_KINDS`), written after the force as ``:push`` (default) or ``:force``:

* ``push`` — the partner's own push: F_s = max(F − K·s, 0), s ≥ 0 the torso's travel along n̂
  since t₀ [m] and K the torso's drive stiffness (:data:`~phri_sim.world.person_body.TORSO`,
  600 N/m). Against a motionless robot the waist presses with F (plus the dance's own
  preload); as the robot yields the push falls as a person's does whose arms and legs extend
  (the dance drive's law, ``person_body.py``, with its target moved F/K into the robot). A
  robot that yields takes the force off the partner; one that stands is a wall.
* ``force`` — a constant F on the torso, whatever it does (a third person shoving the partner
  from behind). Then the waist presses the robot with F − (the partner's own drive, capped at
  ``max_push`` = 80 N) − m·a in any motion that keeps the contact: holding the contact force
  below a limit L for the whole shove needs the robot to accelerate away at (F − 80 − L)/m
  (m ≈ 31 kg: 1.9 m/s² for F = 250 N, L = 110 N) for its whole duration — 5.8 m/s after 3 s,
  beyond any actuator. The kind is there to measure that, not as a bar a robot can meet.

The force is applied through ``qfrc_applied`` on the torso's free joint (its translational
DOFs are world-frame forces), which nothing else in the simulator writes, once per control
period before the physics steps of that period (the bridge's :meth:`advance`).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

import mujoco
import numpy as np
from numpy.typing import NDArray

from phri_sim.world.person_body import TORSO

FloatArray = NDArray[np.float64]

SHOVE_KINDS: tuple[str, ...] = ("push", "force")
"""``push``: the partner's own push, falling with their travel; ``force``: a constant force
(module docstring)."""
SHOVE_LINK = "left_forearm_link"
"""The link the shoved waist presses (the waltz's hold)."""
SHOVE_BODY = TORSO.name
"""The person body the shove acts on."""
_SYNTAX = re.compile(
    r"^\s*(?P<force>[0-9.]+(?:[eE][-+]?[0-9]+)?)\s*N\s*@\s*(?P<time>[0-9.]+)\s*s\s*\+\s*"
    r"(?P<duration>[0-9.]+)\s*s\s*(?::\s*(?P<kind>[a-z]+))?\s*$")


@dataclass(frozen=True)
class ShoveSpec:
    """One shove (module docstring).

    Attributes:
        force: F [N] (> 0).
        time: t₀, sim time the shove starts [s] (≥ 0).
        duration: how long it lasts [s] (> 0).
        kind: one of :data:`SHOVE_KINDS`.
        stiffness: K of the ``push`` kind [N/m] (the torso's drive stiffness).
    """

    force: float
    time: float
    duration: float
    kind: str = "push"
    stiffness: float = TORSO.stiffness

    def __post_init__(self) -> None:
        checks = (("force", self.force, "N", 1e4), ("duration", self.duration, "s", 1e4))
        for name, value, unit, high in checks:
            if not (math.isfinite(value) and 0.0 < value <= high):
                raise ValueError(f"shove {name} {value!r} {unit} refused: allowed (0, {high:g}]")
        if not (math.isfinite(self.time) and self.time >= 0.0):
            raise ValueError(f"shove time {self.time!r} s refused: allowed [0, inf)")
        if self.kind not in SHOVE_KINDS:
            raise ValueError(f"shove kind {self.kind!r} refused: allowed "
                             f"{', '.join(SHOVE_KINDS)}")

    @classmethod
    def parse(cls, text: str) -> ShoveSpec:
        """``FORCE N @ TIME s + DURATION s [:KIND]``, e.g. ``250N@20s+3s`` or
        ``250N@20s+3s:force``; ValueError naming the syntax otherwise."""
        match = _SYNTAX.match(text)
        if match is None:
            raise ValueError(f"shove {text!r} refused: expected FORCE N@TIME s+DURATION s"
                             "[:push|:force], e.g. 250N@20s+3s")
        return cls(float(match["force"]), float(match["time"]), float(match["duration"]),
                   match["kind"] or "push")

    @property
    def end(self) -> float:
        """When the shove ends [s]."""
        return self.time + self.duration

    def magnitude(self, travel: float) -> float:
        """The shove's force [N] after the torso travelled ``travel`` [m] along n̂."""
        if self.kind == "force":
            return self.force
        return max(self.force - self.stiffness * max(travel, 0.0), 0.0)


class Shove:
    """Applies a :class:`ShoveSpec` (or nothing) to a simulation (module docstring).

    Attributes:
        direction: n̂ (world, horizontal unit vector), set at t₀ (``None`` before).
        applied: the force applied in the last period [N].
        peak: the largest force applied [N].
    """

    def __init__(self, spec: ShoveSpec | None) -> None:
        self.spec = spec
        self.direction: FloatArray | None = None
        self.applied = 0.0
        self.peak = 0.0
        self._origin = np.zeros(3)
        self._dofs: slice | None = None

    def apply(self, sim: object, t: float) -> None:
        """Set the shove's force for the control period starting at sim time ``t`` [s] on
        ``sim`` (a :class:`~phri_sim.world.simulation.Simulation`)."""
        spec = self.spec
        if spec is None:
            return
        model, data = sim.model, sim.data  # type: ignore[attr-defined]
        if self._dofs is None:
            body = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, SHOVE_BODY)
            joint = int(model.body_jntadr[body])
            dof = int(model.jnt_dofadr[joint])
            self._dofs = slice(dof, dof + 3)
            self._body = body
        position = np.array(data.xpos[self._body])
        if t < spec.time - 1e-9 or t >= spec.end - 1e-9:
            data.qfrc_applied[self._dofs] = 0.0
            self.applied = 0.0
            return
        if self.direction is None:
            self.direction = self._direction(sim, position)
            self._origin = position
        travel = float((position - self._origin) @ self.direction)
        self.applied = spec.magnitude(travel)
        self.peak = max(self.peak, self.applied)
        data.qfrc_applied[self._dofs] = self.applied * self.direction

    @staticmethod
    def _direction(sim: object, torso: FloatArray) -> FloatArray:
        """n̂ at t₀: the horizontal true contact force on :data:`SHOVE_LINK`, else from the
        torso towards the link."""
        truth = sim.ground_truth().get(SHOVE_LINK)  # type: ignore[attr-defined]
        vector = np.zeros(3)
        if truth is not None:
            vector[0:2] = np.asarray(truth.force_world)[0:2]
        if float(np.hypot(vector[0], vector[1])) < 1e-6:
            _, link = sim.link_pose(SHOVE_LINK)  # type: ignore[attr-defined]
            vector[0:2] = np.asarray(link)[0:2] - torso[0:2]
        norm = float(np.hypot(vector[0], vector[1]))
        if norm < 1e-9:
            return np.array([1.0, 0.0, 0.0])
        return vector / norm
