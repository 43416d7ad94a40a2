"""The simulation core: robot, skins and person in MuJoCo, stepped by commands (pure, no rclpy).

:class:`Simulation` owns the ``MjModel``/``MjData`` of :func:`phri_sim.world.scene.scene_spec` and
is what the bridge node, the scenario runner, the tests and the benchmark drive. It is composed of
four parts, each in its own module:

* :attr:`Simulation.robot` (:class:`~phri_sim.world.robot.SimRobot`): the robot's joints in the
  model, its state (configuration, joint rates, base body twist, link poses), its velocity servos
  and its limits;
* :attr:`Simulation.person` (:class:`~phri_sim.world.person_drive.SimPerson`): the person's body
  parts, their spring–dampers to scripted targets (:class:`~phri_sim.world.person_body.PartTarget`
  per part) and their poses;
* :attr:`Simulation.skins` (:class:`~phri_sim.world.skin_contacts.SimSkins`): the skin patches,
  their taxel forces (footprint model of :mod:`phri_sim.world.skin_footprint`, seeded sensor model
  of :mod:`phri_sim.world.skin_sensor`) and the ground truth per skin link
  (:class:`~phri_sim.world.skin_contacts.LinkGroundTruth`);
* :attr:`Simulation.watchdog` (:class:`~phri_sim.world.command_watchdog.CommandWatchdog`): the
  commands in — base body twist ``[v_x, v_y, ω_z]`` [m/s, rad/s] and per-arm joint velocities
  [rad/s]; stale → zero, NaN/Inf → refused, clipped to the robot's speed limits as the real drivers
  do.

Between the watchdog and the servos sits the plant's drives (:attr:`Simulation.shaper`,
:class:`~phri_sim.world.actuators.CommandShaper`; ``SimConfig.plant``: ``realistic`` by default,
``ideal`` = none).

:meth:`Simulation.step` advances one physics step (2 ms by default). The methods and properties
below are the interface the bridge, the scenarios and the metrics use; each forwards to one part.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

import mujoco
import numpy as np
from numpy.typing import NDArray

from phri_description.description import robot_description
from phri_sim.world.actuators import DEFAULT_PLANT, CommandShaper, plant_named
from phri_sim.world.command_watchdog import CommandError, CommandWatchdog
from phri_sim.world.person_body import PERSON_PARTS, BodyPartSpec, PartTarget
from phri_sim.world.person_drive import SimPerson
from phri_sim.world.protective_stop import ProtectiveStopConfig
from phri_sim.world.robot import ARM_JOINTS, SimRobot
from phri_sim.world.scene import scene_spec
from phri_sim.world.skin_contacts import LinkGroundTruth, SimSkins
from phri_sim.world.skin_footprint import SkinConfig, SkinPatchModel

FloatArray = NDArray[np.float64]

__all__ = ["ARM_JOINTS", "CommandError", "CommandWatchdog", "LinkGroundTruth", "SimConfig",
           "Simulation"]

MIN_TIMESTEP, MAX_TIMESTEP = 0.0005, 0.005
"""Accepted physics steps [s]: at 10 ms the stiff velocity servos and contacts diverge."""


@dataclass(frozen=True)
class SimConfig:
    """Simulation settings.

    Attributes:
        skin: skin sensor model.
        command_timeout: watchdog timeout [s] of sim time.
        seed: seed of the skin sensor model (same seed → same run).
        plant: the plant between commands and servos, a name of
            :data:`phri_sim.world.actuators.PLANTS` (``realistic``: the drives' latency, ramps and
            lag; ``ideal``: the servos follow every command at once).
    """

    skin: SkinConfig = field(default_factory=SkinConfig)
    command_timeout: float = 0.1
    seed: int = 0
    plant: str = DEFAULT_PLANT
    timestep: float | None = None
    """Physics step [s]; ``None`` = the model's 2 ms (the 500 Hz skin sampling period). The
    lock-step runner, which samples the skin once per 10 ms control period, uses 5 ms: the arm
    servos and the joint dampers are integrated implicitly and the softest contact time constant
    is 20 ms, and every scenario's metrics agree with the 2 ms run (docs/phri_sim.md)."""

    protective_stop: ProtectiveStopConfig = field(default_factory=ProtectiveStopConfig)
    """The arms' own protective stop (:mod:`phri_sim.world.protective_stop`)."""

    def __post_init__(self) -> None:
        if self.timestep is not None and not (
            math.isfinite(self.timestep) and MIN_TIMESTEP <= self.timestep <= MAX_TIMESTEP
        ):
            raise ValueError(f"physics timestep must be in [{MIN_TIMESTEP}, {MAX_TIMESTEP}] s, "
                             f"got {self.timestep}")
        plant_named(self.plant)


class Simulation:
    """Robot + skins + person + command watchdog (module docstring).

    Attributes:
        config: the settings.
        model, data: the MuJoCo scene.
        dt: physics step [s].
        robot, person, skins, watchdog: the parts (module docstring).
    """

    def __init__(
        self, config: SimConfig | None = None, parts: tuple[BodyPartSpec, ...] = PERSON_PARTS
    ) -> None:
        self.config = config or SimConfig()
        self.model = scene_spec(parts).compile()
        if self.config.timestep is not None:
            self.model.opt.timestep = self.config.timestep
        self.data = mujoco.MjData(self.model)
        self.dt = float(self.model.opt.timestep)
        desc = robot_description()
        self.robot = SimRobot(self.model, self.data, desc, self.config.protective_stop)
        self.plant = plant_named(self.config.plant)
        self.shaper = CommandShaper(self.plant, self.dt) if self.plant.shapes_commands else None
        self.robot.shaper = self.shaper
        self.person = SimPerson(self.model, self.data, parts)
        self.skins = SimSkins(self.model, self.data, desc.patches, self.config.skin,
                              self.config.seed, self.person.geom_part, self.robot)
        self.watchdog = self._new_watchdog()
        self.on_step: Callable[[], None] | None = None
        """Called after every physics step of :meth:`step` (not while settling): metrics that
        must see every physics state, e.g. peak contact forces."""
        self.reset()

    def _new_watchdog(self) -> CommandWatchdog:
        return CommandWatchdog(self.config.command_timeout, self.robot.velocity_limits)

    # -- life cycle ----------------------------------------------------------------------------
    @property
    def time(self) -> float:
        """Simulation time [s]."""
        return float(self.data.time)

    def reset(self, q: FloatArray | None = None) -> None:
        """Robot at configuration ``q`` (15: x, y, yaw, left arm, right arm; default zeros) at
        rest, every person part at its current target, no command, noise from the seed, time 0."""
        mujoco.mj_resetData(self.model, self.data)
        if q is not None:
            self.robot.set_q(q)
        self.person.reset()
        self.watchdog = self._new_watchdog()
        self._reset_drives()
        self.skins.reset_noise()
        mujoco.mj_forward(self.model, self.data)
        self.skins.invalidate()
        self.robot.protective_stop.reset()

    def _reset_drives(self) -> None:
        """The plant's drives at rest with no command, their clock at sim time 0."""
        if self.shaper is not None:
            self.shaper.reset()

    def settle(self, seconds: float) -> None:
        """Let the person come to rest against the robot before a run: step ``seconds`` [s]
        with every servo commanded to zero velocity and the current targets, then set the clock
        back to 0 (so a scenario starts from a resting contact, not an impact)."""
        if not (math.isfinite(seconds) and seconds >= 0.0):
            raise ValueError(f"settle time must be ≥ 0 [s], got {seconds}")
        self.watchdog = self._new_watchdog()
        # The robot is held rigidly where it stands: the velocity servos alone would creep under
        # the person's load (F / k_v) during the settling, with no controller to correct it.
        q_robot = self.robot.q.copy()
        for _ in range(round(seconds / self.dt)):
            self._apply_controls()
            mujoco.mj_step(self.model, self.data)
            self.robot.hold(q_robot)
        self.robot.hold(q_robot)
        self.data.time = 0.0
        self.person.restart_clock()
        self.watchdog = self._new_watchdog()
        self._reset_drives()
        mujoco.mj_forward(self.model, self.data)
        self.skins.invalidate()
        self.robot.protective_stop.reset()  # what the pinned settling looked like is no collision

    # -- stepping ------------------------------------------------------------------------------
    def command(self, channel: str, values: FloatArray) -> None:
        """Give a command now (see :class:`CommandWatchdog`); raises CommandError if refused."""
        self.watchdog.set(channel, values, self.time)

    def set_target(self, part: str, target: PartTarget, *, teleport: bool = False) -> None:
        """Set a person part's target (:meth:`SimPerson.set_target`)."""
        self.person.set_target(part, target, teleport=teleport)

    def step(self, n: int = 1) -> None:
        """Advance ``n`` physics steps with the current commands and person targets."""
        for _ in range(n):
            self._apply_controls()
            mujoco.mj_step(self.model, self.data)
            if self.on_step is not None:
                self.on_step()

    def _apply_controls(self) -> None:
        t = float(self.data.time)
        self.robot.drive(self.watchdog.applied(t))
        self.person.apply_wrenches(t)
        self.skins.invalidate()

    # -- state out (forwarded to the parts) ----------------------------------------------------
    @property
    def joint_names(self) -> tuple[str, ...]:
        """The 15 names of :attr:`q`, in order."""
        return self.robot.joint_names

    @property
    def q(self) -> FloatArray:
        """Configuration (15) [m, rad]: base x, y, yaw then the arms."""
        return self.robot.q

    @property
    def qd(self) -> FloatArray:
        """Joint rates (15): world rates ẋ, ẏ, ẏaw then arm joint velocities."""
        return self.robot.qd

    def base_twist(self) -> FloatArray:
        """Base body-frame twist [v_x, v_y, ω_z] [m/s, rad/s]."""
        return self.robot.base_twist()

    def link_pose(self, link: str) -> tuple[FloatArray, FloatArray]:
        """(⁰R 3×3, ⁰p [m]) of a link frame."""
        return self.robot.link_pose(link)

    @property
    def parts(self) -> tuple[BodyPartSpec, ...]:
        """The person's parts, in ground-truth order."""
        return self.person.parts

    def part_pose(self, part: str) -> tuple[FloatArray, FloatArray]:
        """(position [m], quaternion w x y z) of a person part in the world."""
        return self.person.part_pose(part)

    @property
    def patches(self) -> dict[str, SkinPatchModel]:
        """Skin patch name → its taxels and footprint model."""
        return self.skins.patches

    @property
    def skin_links(self) -> tuple[str, ...]:
        """The links that carry skin."""
        return self.skins.skin_links

    def clean_skin_forces(self) -> dict[str, FloatArray]:
        """Per-patch noise-free taxel forces [N] now (:meth:`SimSkins.clean_forces`)."""
        return self.skins.clean_forces()

    def skin_reading(self, patch: str, forces: FloatArray) -> FloatArray:
        """What ``patch`` reports [N] for true forces ``forces`` without the driver in the loop
        (:meth:`SimSkins.reading`)."""
        return self.skins.reading(patch, forces)

    def ground_truth(self) -> Mapping[str, LinkGroundTruth]:
        """True contact per skin link at the current state (see :class:`LinkGroundTruth`)."""
        return self.skins.ground_truth()
