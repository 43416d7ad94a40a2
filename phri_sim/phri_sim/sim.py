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
        self.version = 0
        """Incremented by every :meth:`set` (accepted or refused)."""

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
        self.version += 1
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

    def next_change(self, t: float) -> float:
        """Sim time [s] after which a channel that is fresh at ``t`` goes stale (inf if none
        will): until then, and without a new :meth:`set`, :meth:`current` keeps its value."""
        ends = [s + self.timeout for s in self._times.values() if t - s <= self.timeout]
        return min(ends) if ends else math.inf

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
    timestep: float | None = None
    """Physics step [s]; ``None`` = the model's 2 ms (the 500 Hz skin sampling period). The
    lock-step runner, which samples the skin once per 10 ms control period, uses 5 ms: the arm
    servos and the joint dampers are integrated implicitly and the softest contact time constant
    is 20 ms, and every scenario's metrics agree with the 2 ms run (docs/phri_sim.md)."""

    def __post_init__(self) -> None:
        if self.timestep is not None and not (
            math.isfinite(self.timestep) and MIN_TIMESTEP <= self.timestep <= MAX_TIMESTEP
        ):
            raise ValueError(f"physics timestep must be in [{MIN_TIMESTEP}, {MAX_TIMESTEP}] s, "
                             f"got {self.timestep}")


MIN_TIMESTEP, MAX_TIMESTEP = 0.0005, 0.005
"""Accepted physics steps [s]: at 10 ms the stiff velocity servos and contacts diverge."""


class Simulation:
    """Robot + skins + person (module docstring)."""

    def __init__(
        self, config: SimConfig | None = None, parts: tuple[BodyPartSpec, ...] = PERSON_PARTS
    ) -> None:
        self.config = config or SimConfig()
        self.model = scene_spec(parts).compile()
        if self.config.timestep is not None:
            self.model.opt.timestep = self.config.timestep
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
        n_parts = len(parts)
        self._part_index = {p.name: i for i, p in enumerate(parts)}
        self._part_bodies = np.array([self.part_body[p.name] for p in parts], dtype=np.intp)
        dofs = np.array([self.part_dof[p.name] for p in parts], dtype=np.intp)
        self._lin_dofs = dofs[:, None] + np.arange(3)
        self._ang_dofs = dofs[:, None] + np.arange(3, 6)
        self._k_lin = np.array([p.stiffness for p in parts])
        self._d_lin = np.array([p.damping for p in parts])
        self._k_rot = np.array([p.rot_stiffness for p in parts])
        self._d_rot = np.array([p.rot_damping for p in parts])
        self._part_body_list = [int(b) for b in self._part_bodies]
        self._part_dof_list = [int(x) for x in dofs]
        self._rot_err = np.zeros(3)
        self._quat = np.zeros(4)
        self._torque = np.zeros(3)
        self._torque_world = np.zeros(3)
        self._target_pos = np.zeros((n_parts, 3))
        self._target_vel = np.zeros((n_parts, 3))
        self._target_time = np.zeros(n_parts)
        self._target_cos = np.ones(n_parts)
        self._target_sin = np.zeros(n_parts)
        self.targets: dict[str, PartTarget] = {}
        for p in parts:
            self.set_target(p.name, PartTarget(np.array(p.parking), np.zeros(3)))
        self._yaw_qpos = int(self.qpos_idx[2])
        self._act_x, self._act_y = int(self.act_idx[0]), int(self.act_idx[1])
        self._act_rest = self.act_idx[2:]
        self._cmd = np.zeros(len(JOINT_NAMES))
        self._cmd_version = -1
        self._cmd_source: CommandWatchdog | None = None
        self._cmd_valid_until = -math.inf
        # Geoms of a part, including those on its tissue layer (a child body of the part).
        self._person_geoms = {
            g: p for p in parts for g in range(m.ngeom)
            if m.body_rootid[m.geom_bodyid[g]] == self.part_body[p.name]
        }
        self._tissue_dofs: dict[str, tuple[int, int]] = {}
        self._tissue_qpos: dict[str, tuple[int, int]] = {}
        for p in parts:
            if p.tissue is not None:
                joints = [m.joint(f"{p.tissue_body}_{a}").id for a in ("x", "y")]
                self._tissue_qpos[p.name] = (int(m.jnt_qposadr[joints[0]]),
                                             int(m.jnt_qposadr[joints[1]]))
                self._tissue_dofs[p.name] = (int(m.jnt_dofadr[joints[0]]),
                                             int(m.jnt_dofadr[joints[1]]))

        # Skins.
        self.patches = {p.name: SkinPatchModel(layout_for_patch(p), self.config.skin)
                        for p in desc.patches}
        self.patch_link = {p.name: p.link for p in desc.patches}
        self.skin_links = tuple(dict.fromkeys(p.link for p in desc.patches))
        self.link_body = {link: m.body(link).id for link in self.skin_links}
        self._body_link = {b: link for link, b in self.link_body.items()}
        self._truth: dict[str, LinkGroundTruth] = {}
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
        self._target_time[:] = 0.0
        self.watchdog = CommandWatchdog(self.config.command_timeout)
        self.rng = np.random.default_rng(self.config.seed)
        mujoco.mj_forward(self.model, self.data)
        self._dirty = True

    def _place_part(self, name: str, target: PartTarget) -> None:
        adr = self.part_qpos[name]
        self.data.qpos[adr : adr + 3] = target.position if target.rest is None else target.rest
        half = 0.5 * target.yaw
        self.data.qpos[adr + 3 : adr + 7] = (math.cos(half), 0.0, 0.0, math.sin(half))
        dof = self.part_dof[name]
        self.data.qvel[dof : dof + 6] = 0.0
        if name in self._tissue_qpos:
            self.data.qpos[list(self._tissue_qpos[name])] = 0.0
            self.data.qvel[list(self._tissue_dofs[name])] = 0.0

    def set_target(self, part: str, target: PartTarget, *, teleport: bool = False) -> None:
        """Set a part's spring target (from now on it moves with ``target.velocity`` until the
        next call); ``teleport`` also moves the part there at rest."""
        i = self._part_index.get(part)
        if i is None:
            raise KeyError(f"no person part {part!r}")
        self.targets[part] = target
        self._target_pos[i] = target.position
        self._target_vel[i] = target.velocity
        self._target_time[i] = self.data.time
        half = 0.5 * target.yaw
        self._target_cos[i], self._target_sin[i] = math.cos(half), math.sin(half)
        if teleport:
            self._place_part(part, target)

    def tissue_deflection(self, part: str) -> FloatArray:
        """Displacement of a part's tissue layer from rest in the part's frame (x, y) [m]
        (zeros for a part without tissue)."""
        if part not in self._tissue_qpos:
            return np.zeros(2)
        return np.asarray(self.data.qpos[list(self._tissue_qpos[part])], dtype=np.float64)

    def settle(self, seconds: float) -> None:
        """Let the person come to rest against the robot before a run: step ``seconds`` [s]
        with every servo commanded to zero velocity and the current targets, then set the clock
        back to 0 (so a scenario starts from a resting contact, not an impact)."""
        if not (math.isfinite(seconds) and seconds >= 0.0):
            raise ValueError(f"settle time must be ≥ 0 [s], got {seconds}")
        self.watchdog = CommandWatchdog(self.config.command_timeout)
        # The robot is held rigidly where it stands: the velocity servos alone would creep under
        # the person's load (F / k_v) during the settling, with no controller to correct it.
        q_robot = self.data.qpos[self.qpos_idx].copy()
        for _ in range(round(seconds / self.dt)):
            self._apply_controls()
            mujoco.mj_step(self.model, self.data)
            self.data.qpos[self.qpos_idx] = q_robot
            self.data.qvel[self.dof_idx] = 0.0
        self.data.time = 0.0
        self._target_time[:] = 0.0
        self.data.qvel[self.dof_idx] = 0.0
        self.watchdog = CommandWatchdog(self.config.command_timeout)
        mujoco.mj_forward(self.model, self.data)
        self._dirty = True

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
        d = self.data
        t = float(d.time)
        wd = self.watchdog
        # (Recomputed a hair early at the staleness instant, where t − t_set vs timeout is
        # decided by rounding.)
        if wd is not self._cmd_source or wd.version != self._cmd_version or (
            t >= self._cmd_valid_until - 1e-9
        ):
            # The servo set points change only when a command arrives or one goes stale.
            self._cmd = self.applied_command()
            self._cmd_version = wd.version
            self._cmd_source = wd
            self._cmd_valid_until = wd.next_change(t)
        u = self._cmd
        yaw = float(d.qpos[self._yaw_qpos])
        c, s = math.cos(yaw), math.sin(yaw)
        ctrl = d.ctrl
        ctrl[self._act_x] = c * u[0] - s * u[1]
        ctrl[self._act_y] = s * u[0] + c * u[1]
        ctrl[self._act_rest] = u[2:]
        self._person_wrenches(t)
        self._dirty = True

    def _person_wrenches(self, t: float) -> None:
        """Spring–damper wrenches of every part towards its target (person.py) [N, N·m]. The
        target position moves with its velocity from when it was set, so a script evaluated
        once per control period still drives a smooth target."""
        d = self.data
        xfrc, xpos, qvel, xquat = d.xfrc_applied, d.xpos, d.qvel, d.xquat
        err, quat, torque = self._rot_err, self._quat, self._torque
        for i, b in enumerate(self._part_body_list):
            dof = self._part_dof_list[i]
            lag = t - self._target_time[i]
            vel = self._target_vel[i]
            xfrc[b, 0:3] = self._k_lin[i] * (self._target_pos[i] + vel * lag - xpos[b]) + (
                self._d_lin[i] * (vel - qvel[dof : dof + 3]))
            # Orientation spring: mju_subQuat gives the body-frame rotation vector from the
            # current to the target orientation; the free joint's angular velocity is body-frame.
            quat[0], quat[3] = self._target_cos[i], self._target_sin[i]
            mujoco.mju_subQuat(err, quat, xquat[b])
            torque[:] = self._k_rot[i] * err - self._d_rot[i] * qvel[dof + 3 : dof + 6]
            mujoco.mju_rotVecQuat(self._torque_world, torque, xquat[b])
            xfrc[b, 3:6] = self._torque_world

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

    def clean_skin_forces(self) -> dict[str, FloatArray]:
        """Per-patch noise-free taxel forces [N] now (patch → (N,)), the footprint model of
        :mod:`phri_sim.skin`; an untouched patch is all zeros."""
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
            out[name] = forces
        return out

    def add_skin_noise(self, patch: str, forces: FloatArray) -> FloatArray:
        """One sample of a patch's sensor noise added to ``forces`` (new array, clipped at 0);
        draws from the simulation's seeded generator."""
        return self.patches[patch].add_noise(forces, self.rng)

    def skin_forces(self, noise: bool = True) -> dict[str, FloatArray]:
        """Per-patch taxel forces [N] now (patch → (N,)), footprint model of :mod:`phri_sim.skin`,
        plus sensor noise when ``noise``."""
        clean = self.clean_skin_forces()
        if not noise:
            return clean
        return {name: self.add_skin_noise(name, forces) for name, forces in clean.items()}

    def ground_truth(self) -> Mapping[str, LinkGroundTruth]:
        """True contact per skin link at the current state (see :class:`LinkGroundTruth`)."""
        self._update_contacts()
        return self._truth
