"""The simulation core: robot, skins and person in MuJoCo, stepped by commands (pure, no rclpy).

:class:`Simulation` owns the ``MjModel``/``MjData`` of :func:`phri_sim.scene.scene_spec` and is
what the bridge node, the scenario runner, the tests and the benchmark drive:

* commands in — base body twist ``[v_x, v_y, ω_z]`` [m/s, rad/s] and per-arm joint velocities
  [rad/s] through a :class:`CommandWatchdog` (stale → zero, NaN/Inf → refused), clipped to the
  robot's speed limits as the real drivers do;
* the person's targets in (:class:`~phri_sim.person.PartTarget` per part);
* :meth:`Simulation.step` — one physics step (2 ms);
* state out — joint positions/velocities, base pose and body twist, per-patch taxel forces
  (:meth:`skin_forces`, the footprint model of :mod:`phri_sim.skin`), ground truth per skin link
  (:meth:`ground_truth`: the true contact force and centre) and the person's poses.

Base kinematics: q_b = [x, y, yaw] of ``base_link`` in ``odom``. A body twist (v_x, v_y, ω_z)
becomes the world rates ẋ = cos(yaw) v_x − sin(yaw) v_y, ẏ = sin(yaw) v_x + cos(yaw) v_y,
ẏaw = ω_z, the set points of the base's velocity servos.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field

import mujoco
import numpy as np
from numpy.typing import NDArray

from phri_description.description import JOINT_NAMES, robot_description
from phri_sim.person import PERSON_PARTS, BodyPartSpec, PartTarget
from phri_sim.scene import ACTUATOR_SUFFIX, scene_spec
from phri_sim.skin import (
    CapsuleShape,
    Shape,
    SkinConfig,
    SkinPatchModel,
    SphereShape,
    layout_for_patch,
)

FloatArray = NDArray[np.float64]

ARM_SIDES: tuple[str, str] = ("left", "right")
ARM_JOINTS: dict[str, tuple[str, ...]] = {
    side: tuple(n for n in JOINT_NAMES[3:] if n.startswith(side + "_")) for side in ARM_SIDES
}
"""Joint names per arm in UR order (the order of the arm command arrays)."""
COMMAND_SIZES: dict[str, int] = {"base": 3, "left": 6, "right": 6}


class CommandError(ValueError):
    """A command is malformed (wrong size, NaN/Inf)."""


class CommandWatchdog:
    """Latest command per channel with a staleness timeout in simulation time.

    Channels: ``base`` (3: v_x, v_y, ω_z) and ``left``/``right`` (6 joint velocities). A channel
    that has not been commanded within ``timeout`` [s] of sim time reads as zero, so a lost
    command stream stops the robot (design §8).
    """

    def __init__(self, timeout: float) -> None:
        if not (math.isfinite(timeout) and timeout > 0.0):
            raise ValueError(f"command timeout must be > 0 [s], got {timeout}")
        self.timeout = timeout
        self._values = {k: np.zeros(n) for k, n in COMMAND_SIZES.items()}
        self._times = dict.fromkeys(COMMAND_SIZES, -math.inf)
        self.refused = 0

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
        if arr.shape != (n,) or not np.all(np.isfinite(arr)):
            self.refused += 1
            self._values[channel] = np.zeros(n)
            self._times[channel] = -math.inf
            raise CommandError(
                f"{channel} command must be {n} finite numbers, got {arr.tolist()}"
            )
        self._values[channel] = arr.copy()
        self._times[channel] = t

    def current(self, channel: str, t: float) -> FloatArray:
        """The command to apply at sim time ``t`` (zero when stale or never received)."""
        if t - self._times[channel] > self.timeout:
            return np.zeros(COMMAND_SIZES[channel])
        return self._values[channel]

    def stale(self, channel: str, t: float) -> bool:
        """Whether ``channel`` reads as zero because of the timeout."""
        return t - self._times[channel] > self.timeout


@dataclass
class LinkGroundTruth:
    """True contact on one skin link (from the physics, not from the skin).

    Attributes:
        link: link name.
        in_contact: whether any person geom touches the link.
        force_world: total contact force the person exerts on the link, world frame [N].
        force_link: the same in the link frame [N].
        normal_force: sum of the contacts' normal force magnitudes [N].
        center_link: force-weighted mean contact point in the link frame [m].
        skin_force: normal force that landed on taxels (≤ ``normal_force``; less when part of the
            contact is off the covered area) [N].
    """

    link: str
    in_contact: bool = False
    force_world: FloatArray = field(default_factory=lambda: np.zeros(3))
    force_link: FloatArray = field(default_factory=lambda: np.zeros(3))
    normal_force: float = 0.0
    center_link: FloatArray = field(default_factory=lambda: np.zeros(3))
    skin_force: float = 0.0


@dataclass(frozen=True)
class SimConfig:
    """Simulation settings.

    Attributes:
        skin: skin sensor model.
        command_timeout: watchdog timeout [s] of sim time.
        seed: seed of the sensor-noise generator (same seed → same run).
    """

    skin: SkinConfig = field(default_factory=SkinConfig)
    command_timeout: float = 0.1
    seed: int = 0


class Simulation:
    """Robot + skins + person (module docstring)."""

    def __init__(
        self, config: SimConfig | None = None, parts: tuple[BodyPartSpec, ...] = PERSON_PARTS
    ) -> None:
        self.config = config or SimConfig()
        self.model = scene_spec(parts).compile()
        self.data = mujoco.MjData(self.model)
        m = self.model
        self.dt = float(m.opt.timestep)
        self.joint_names = JOINT_NAMES
        self.qpos_idx = np.array([m.jnt_qposadr[m.joint(n).id] for n in JOINT_NAMES])
        self.dof_idx = np.array([m.jnt_dofadr[m.joint(n).id] for n in JOINT_NAMES])
        self.act_idx = np.array([m.actuator(n + ACTUATOR_SUFFIX).id for n in JOINT_NAMES])
        desc = robot_description()
        self.position_limits = desc.position_limits()
        self.velocity_limits = desc.velocity_limits()
        self.watchdog = CommandWatchdog(self.config.command_timeout)
        self.rng = np.random.default_rng(self.config.seed)

        # Person.
        self.parts = parts
        self.part_body = {p.name: m.body(p.name).id for p in parts}
        self.part_qpos = {p.name: m.jnt_qposadr[m.joint(p.name + "_free").id] for p in parts}
        self.part_dof = {p.name: m.jnt_dofadr[m.joint(p.name + "_free").id] for p in parts}
        self.targets: dict[str, PartTarget] = {
            p.name: PartTarget(np.array(p.parking), np.zeros(3)) for p in parts
        }
        self._person_geoms = {
            g: p for p in parts for g in range(m.ngeom)
            if m.geom_bodyid[g] == self.part_body[p.name]
        }

        # Skins.
        self.patches = {p.name: SkinPatchModel(layout_for_patch(p), self.config.skin)
                        for p in desc.patches}
        self.patch_link = {p.name: p.link for p in desc.patches}
        self.skin_links = tuple(dict.fromkeys(p.link for p in desc.patches))
        self.link_body = {link: m.body(link).id for link in self.skin_links}
        self._body_link = {b: link for link, b in self.link_body.items()}
        self._truth: dict[str, LinkGroundTruth] = {}
        self._rot_err = np.zeros(3)
        self._quat = np.zeros(4)
        self._dirty = True
        self._contacts: dict[str, list[tuple[int, float]]] = {}
        self.reset()

    # -- state ---------------------------------------------------------------------------------
    @property
    def time(self) -> float:
        """Simulation time [s]."""
        return float(self.data.time)

    def reset(self, q: FloatArray | None = None) -> None:
        """Robot at configuration ``q`` (15: x, y, yaw, left arm, right arm; default zeros) at
        rest, every person part at its current target, time 0."""
        mujoco.mj_resetData(self.model, self.data)
        if q is not None:
            q = np.asarray(q, dtype=np.float64)
            if q.shape != (len(JOINT_NAMES),) or not np.all(np.isfinite(q)):
                raise ValueError(f"q must be {len(JOINT_NAMES)} finite numbers")
            self.data.qpos[self.qpos_idx] = q
        for name, target in self.targets.items():
            self._place_part(name, target)
        self.watchdog = CommandWatchdog(self.config.command_timeout)
        self.rng = np.random.default_rng(self.config.seed)
        mujoco.mj_forward(self.model, self.data)
        self._dirty = True

    def _place_part(self, name: str, target: PartTarget) -> None:
        adr = self.part_qpos[name]
        self.data.qpos[adr : adr + 3] = target.position
        half = 0.5 * target.yaw
        self.data.qpos[adr + 3 : adr + 7] = (math.cos(half), 0.0, 0.0, math.sin(half))
        dof = self.part_dof[name]
        self.data.qvel[dof : dof + 6] = 0.0

    def set_target(self, part: str, target: PartTarget, *, teleport: bool = False) -> None:
        """Set a part's spring target; ``teleport`` also moves the part there at rest."""
        if part not in self.targets:
            raise KeyError(f"no person part {part!r}")
        self.targets[part] = target
        if teleport:
            self._place_part(part, target)

    @property
    def q(self) -> FloatArray:
        """Configuration (15) [m, rad]: base x, y, yaw then the arms."""
        return np.asarray(self.data.qpos[self.qpos_idx], dtype=np.float64)

    @property
    def qd(self) -> FloatArray:
        """Joint rates (15): world rates ẋ, ẏ, ẏaw then arm joint velocities."""
        return np.asarray(self.data.qvel[self.dof_idx], dtype=np.float64)

    def base_twist(self) -> FloatArray:
        """Base body-frame twist [v_x, v_y, ω_z] [m/s, rad/s]."""
        qd, yaw = self.qd, float(self.q[2])
        c, s = math.cos(yaw), math.sin(yaw)
        return np.array([c * qd[0] + s * qd[1], -s * qd[0] + c * qd[1], qd[2]])

    def arm_state(self, side: str) -> tuple[FloatArray, FloatArray]:
        """(positions, velocities) of one arm in UR order [rad, rad/s]."""
        i = 3 if side == "left" else 9
        return self.q[i : i + 6], self.qd[i : i + 6]

    def part_pose(self, part: str) -> tuple[FloatArray, FloatArray]:
        """(position [m], quaternion w x y z) of a person part in the world."""
        b = self.part_body[part]
        return self.data.xpos[b].copy(), self.data.xquat[b].copy()

    def link_pose(self, link: str) -> tuple[FloatArray, FloatArray]:
        """(⁰R 3×3, ⁰p [m]) of a link frame (body frame = description link frame)."""
        b = self.model.body(link).id
        return self.data.xmat[b].reshape(3, 3).copy(), self.data.xpos[b].copy()

    # -- commands ------------------------------------------------------------------------------
    def command(self, channel: str, values: FloatArray) -> None:
        """Give a command now (see :class:`CommandWatchdog`); raises CommandError if refused."""
        self.watchdog.set(channel, values, self.time)

    def applied_command(self) -> FloatArray:
        """The 15 velocities the servos follow now: body twist then arms, after the watchdog and
        the robot's speed limits."""
        t = self.time
        u = np.concatenate([self.watchdog.current(k, t) for k in ("base", "left", "right")])
        return np.asarray(np.clip(u, -self.velocity_limits, self.velocity_limits))

    # -- stepping ------------------------------------------------------------------------------
    def step(self, n: int = 1) -> None:
        """Advance ``n`` physics steps with the current commands and person targets."""
        for _ in range(n):
            self._apply_controls()
            mujoco.mj_step(self.model, self.data)

    def _apply_controls(self) -> None:
        u = self.applied_command()
        yaw = float(self.data.qpos[self.qpos_idx[2]])
        c, s = math.cos(yaw), math.sin(yaw)
        rates = u.copy()
        rates[0] = c * u[0] - s * u[1]
        rates[1] = s * u[0] + c * u[1]
        self.data.ctrl[self.act_idx] = rates
        d = self.data
        xfrc = d.xfrc_applied
        err = self._rot_err
        for part in self.parts:
            b = self.part_body[part.name]
            dof = self.part_dof[part.name]
            target = self.targets[part.name]
            force = part.stiffness * (target.position - d.xpos[b]) + part.damping * (
                target.velocity - d.qvel[dof : dof + 3]
            )
            # Orientation spring: mju_subQuat gives the body-frame rotation vector from the
            # current to the target orientation; the free joint's angular velocity is body-frame.
            half = 0.5 * target.yaw
            self._quat[0], self._quat[3] = math.cos(half), math.sin(half)
            mujoco.mju_subQuat(err, self._quat, d.xquat[b])
            torque_body = part.rot_stiffness * err - part.rot_damping * d.qvel[dof + 3 : dof + 6]
            xfrc[b, 0:3] = force
            xfrc[b, 3:6] = d.xmat[b].reshape(3, 3) @ torque_body
        self._dirty = True

    # -- contacts, skin and ground truth --------------------------------------------------------
    def _update_contacts(self) -> None:
        """Collect person↔skin-link contacts: per link, (person geom, normal force) and the
        ground truth (lazily, once per state)."""
        if not self._dirty:
            return
        self._dirty = False
        m, d = self.model, self.data
        truth = {link: LinkGroundTruth(link) for link in self.skin_links}
        per_link: dict[str, dict[int, float]] = {link: {} for link in self.skin_links}
        weighted = {link: np.zeros(3) for link in self.skin_links}
        wrench = np.zeros(6)
        for i in range(d.ncon):
            con = d.contact[i]
            g1, g2 = int(con.geom1), int(con.geom2)
            if g1 in self._person_geoms:
                person, robot, sign = g1, g2, 1.0
            elif g2 in self._person_geoms:
                person, robot, sign = g2, g1, -1.0
            else:
                continue
            link = self._body_link.get(int(m.geom_bodyid[robot]))
            if link is None:
                continue
            mujoco.mj_contactForce(m, d, i, wrench)
            frame = con.frame.reshape(3, 3)
            # Contact force acts on geom2 along +normal (frame row 0 points geom1 → geom2).
            f_world = sign * (frame.T @ wrench[:3])
            fn = float(wrench[0])
            gt = truth[link]
            gt.in_contact = True
            gt.force_world += f_world
            gt.normal_force += fn
            weighted[link] += fn * con.pos
            per_link[link][person] = per_link[link].get(person, 0.0) + fn
        for link, gt in truth.items():
            if gt.in_contact:
                rot, pos = self.link_pose(link)
                gt.force_link = rot.T @ gt.force_world
                if gt.normal_force > 0.0:
                    gt.center_link = rot.T @ (weighted[link] / gt.normal_force - pos)
        self._truth = truth
        self._contacts = {link: list(v.items()) for link, v in per_link.items()}

    def _shape(self, geom: int) -> Shape:
        m, d = self.model, self.data
        pos = d.geom_xpos[geom].copy()
        radius = float(m.geom_size[geom][0])
        if m.geom_type[geom] == mujoco.mjtGeom.mjGEOM_SPHERE:
            return SphereShape(pos, radius)
        axis = d.geom_xmat[geom].reshape(3, 3)[:, 2] * float(m.geom_size[geom][1])
        return CapsuleShape(pos - axis, pos + axis, radius)

    def skin_forces(self, noise: bool = True) -> dict[str, FloatArray]:
        """Per-patch taxel forces [N] now (patch → (N,)), footprint model of :mod:`phri_sim.skin`,
        plus sensor noise when ``noise``."""
        self._update_contacts()
        out: dict[str, FloatArray] = {}
        for name, patch in self.patches.items():
            link = self.patch_link[name]
            contacts = self._contacts.get(link, [])
            if contacts:
                rot, pos = self.link_pose(link)
                forces = patch.forces(rot, pos, [(self._shape(g), fn) for g, fn in contacts])
            else:
                forces = np.zeros(patch.size)
            self._truth[link].skin_force = float(forces.sum())
            out[name] = patch.add_noise(forces, self.rng) if noise else forces
        return out

    def ground_truth(self) -> Mapping[str, LinkGroundTruth]:
        """True contact per skin link at the current state (see :class:`LinkGroundTruth`)."""
        self._update_contacts()
        return self._truth
