"""The whole-body controller: contact states + configuration → joint velocity command (pure).

One :meth:`WholeBodyController.step` is the paper's control cycle: for each skin link the task of
:mod:`~wholebody_controller.contact_task` ((10)–(21), Algorithm 1), the contact-centre Jacobian
(8) from the kinematics, then the QP (22)–(23).

Decision variable. The QP solves directly for the command ``u = [v_x, v_y, ω_z, q̇_left (6),
q̇_right (6)]``, with the base part a twist in the *base* frame (what ``/cmd_vel`` carries), so the
velocity limits of Table II bound what the base is actually told. The kinematics' base columns
are for the world rates ``[ẋ, ẏ, ẏaw]`` of q_b = [x, y, yaw] (odom frame); since
``[ẋ, ẏ] = R(yaw) [v_x, v_y]``, the Jacobian is right-multiplied by ``blockdiag(R(yaw), 1, I)``.
That rotation preserves ‖u‖, so ε‖u‖² equals ε‖q̇‖² of (23). Base x/y position limits would not be
boxes in u; they must be infinite (as on the real robot) — yaw limits are allowed.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from phri_common.contact import ContactState
from wholebody_controller.config import ControllerConfig
from wholebody_controller.contact_task import ContactTask, TaskOutput
from wholebody_controller.qp import (
    QPError,
    QPProblem,
    QPSolver,
    build_qp,
    make_solver,
    velocity_bounds,
)

Array = NDArray[np.float64]

BASE_JOINTS: tuple[str, str, str] = ("base_x", "base_y", "base_yaw")


class KinematicsModel(Protocol):
    """What the controller needs from the robot kinematics (``RobotKinematics`` satisfies it).

    Joint order: ``base_x, base_y, base_yaw`` (world/odom frame), then the arm joints.
    """

    @property
    def joint_names(self) -> Sequence[str]: ...

    @property
    def position_limits(self) -> Array:
        """n×2 [lower, upper] [rad] / [m]; ±inf where unlimited."""
        ...

    @property
    def velocity_limits(self) -> Array:
        """n, symmetric bounds [rad/s] / [m/s]."""
        ...

    def update(self, q: Array) -> None:
        """Set the configuration q (n) for the following queries."""
        ...

    def link_pose(self, link: str) -> tuple[Array, Array]:
        """(⁰R_i 3×3, ⁰p_γi 3) of a link frame in the world."""
        ...

    def point_jacobian(self, link: str, point: Array) -> Array:
        """6×n world-frame [linear; angular] Jacobian of a point fixed on the link (8)."""
        ...


@dataclass(frozen=True)
class StepResult:
    """One control cycle's outcome.

    Attributes:
        command: u = [v_x, v_y, ω_z (base frame), arm joint velocities] [m/s, rad/s].
        qdot: the same motion as rates of q = [x, y, yaw, arms] (world frame) [m/s, rad/s].
        tasks: per-link task outputs (ψ, phase, deflection, track force …), config order.
        tracking_errors: (21) at the solution, ``b_i − J_i u`` per link [m/s, rad/s].
        problem: the QP that was solved.
    """

    command: Array
    qdot: Array
    tasks: tuple[TaskOutput, ...]
    tracking_errors: tuple[Array, ...]
    problem: QPProblem


def base_command_to_rates(command: Array, yaw: float) -> Array:
    """Body twist + arm velocities → q̇ (world rates of x, y, yaw)."""
    c, s = math.cos(yaw), math.sin(yaw)
    qdot = np.array(command, dtype=np.float64, copy=True)
    qdot[0] = c * command[0] - s * command[1]
    qdot[1] = s * command[0] + c * command[1]
    return qdot


class WholeBodyController:
    """Admittance at every contact centre, soft dynamic priorities, one QP (Sec. IV-B – V)."""

    def __init__(
        self,
        kinematics: KinematicsModel,
        config: ControllerConfig | None = None,
        solver: QPSolver | None = None,
    ) -> None:
        self.kinematics = kinematics
        names = list(kinematics.joint_names)
        if tuple(names[:3]) != BASE_JOINTS:
            raise ValueError(f"kinematics must start with {BASE_JOINTS}, got {names[:3]}")
        self.joint_names: tuple[str, ...] = tuple(names)
        self.n = len(names)
        limits = np.asarray(kinematics.position_limits, dtype=np.float64)
        if np.any(np.isfinite(limits[0:2])):
            raise ValueError("base x/y position limits must be infinite (see module docstring)")
        self._robot_position_limits = limits
        self._robot_velocity_limits = np.asarray(kinematics.velocity_limits, dtype=np.float64)
        self._solver_override = solver
        self.config = ControllerConfig()
        self.tasks: list[ContactTask] = []
        self.configure(config or ControllerConfig())

    def configure(self, config: ControllerConfig) -> None:
        """Apply a new configuration. Tasks whose settings are unchanged keep their state."""
        previous = {task.config.link: task for task in self.tasks}
        old = self.config
        same_globals = (
            old.k_eta, old.b, old.k_p, old.psi_thr, old.region_margin, old.rate_hz
        ) == (
            config.k_eta, config.b, config.k_p, config.psi_thr, config.region_margin,
            config.rate_hz,
        )
        tasks = []
        for link_cfg in config.links:
            keep = previous.get(link_cfg.link)
            if keep is not None and same_globals and keep.config == link_cfg:
                tasks.append(keep)
                continue
            tasks.append(
                ContactTask(
                    link_cfg, k_eta=config.k_eta, b=config.b, k_p=config.k_p,
                    psi_thr=config.psi_thr, region_margin=config.region_margin, dt=config.dt,
                )
            )
        lower = self._robot_position_limits[:, 0].copy()
        upper = self._robot_position_limits[:, 1].copy()
        index = {name: i for i, name in enumerate(self.joint_names)}
        for rng in config.joint_ranges:
            if rng.joint not in index:
                raise ValueError(f"joint range for unknown joint {rng.joint!r}")
            i = index[rng.joint]
            if i < 2:
                raise ValueError("base x/y cannot have a position range (see module docstring)")
            lower[i] = max(lower[i], rng.lower)
            upper[i] = min(upper[i], rng.upper)
            if lower[i] > upper[i]:
                raise ValueError(f"joint range of {rng.joint} does not meet its joint limits")
        vmax = np.minimum(self._robot_velocity_limits, config.velocity_limit)
        if self._solver_override is not None:
            self.solver: QPSolver = self._solver_override
        elif getattr(self, "solver", None) is None or self.solver.name != config.solver:
            self.solver = make_solver(config.solver)
        self.position_lower, self.position_upper = lower, upper
        self.velocity_upper = vmax
        self.velocity_lower = -vmax
        self.tasks = tasks
        self.config = config

    def reset(self) -> None:
        """Every task back to inactive (e.g. after stale input)."""
        for task in self.tasks:
            task.reset()

    def step(self, q: Array, contacts: Mapping[str, ContactState]) -> StepResult:
        """One control cycle.

        Args:
            q: configuration [x, y, yaw, arms] [m, rad].
            contacts: latest contact state per link (missing link = no contact).

        Raises:
            ValueError: q has the wrong size or is not finite.
            QPError: the QP failed.
        """
        q = np.asarray(q, dtype=np.float64)
        if q.shape != (self.n,) or not np.all(np.isfinite(q)):
            raise ValueError(f"configuration must be {self.n} finite numbers, got {q}")
        kin = self.kinematics
        kin.update(q)
        yaw = float(q[2])
        c, s = math.cos(yaw), math.sin(yaw)
        outputs: list[TaskOutput] = []
        jacobians: list[Array] = []
        for task in self.tasks:
            link = task.config.link
            contact = contacts.get(link)
            if contact is None:
                contact = ContactState.no_contact(link, 0)
            rot, pos = kin.link_pose(link)
            out = task.update(contact, rot, pos, yaw)
            outputs.append(out)
            jacobians.append(kin.point_jacobian(link, out.point))
        stacked = np.concatenate(jacobians)
        # World base rates → base-frame twist (module docstring).
        stacked[:, 0:2] = stacked[:, 0:2] @ np.array(((c, -s), (s, c)))
        targets = [o.target for o in outputs]
        lower, upper = velocity_bounds(
            q, self.position_lower, self.position_upper, self.velocity_lower,
            self.velocity_upper, self.config.horizon,
        )
        target = np.concatenate(targets)
        problem = build_qp(
            [stacked], [target], [o.psi for o in outputs], self.config.epsilon, lower, upper
        )
        command = self.solver.solve(problem)
        if not np.isfinite(float(command.sum())):
            raise QPError("non-finite command")
        residual = target - stacked @ command
        errors = tuple(residual[6 * i : 6 * i + 6] for i in range(len(outputs)))
        return StepResult(
            command=command,
            qdot=base_command_to_rates(command, yaw),
            tasks=tuple(outputs),
            tracking_errors=errors,
            problem=problem,
        )
