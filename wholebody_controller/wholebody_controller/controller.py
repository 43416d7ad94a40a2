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

Speed (design §7: the step must fit well inside 2 ms, beside contact estimation). At this size a
numpy call costs as much as dozens of float operations, so the step makes few of them: q is
validated once here (as floats), the tasks run on plain floats and return their
:class:`TaskOutput` directly (:meth:`ContactTask.step`), targets and weights of all tasks
become one array, the Jacobians are written in place into one stacked buffer
(``point_jacobian(..., out=)``), the base-frame rotation is one
product with a 15×15 matrix, :class:`~wholebody_controller.qp.QPBuilder` forms H and g with two
products on ``2ΨJ``, q̇ comes from the command's floats, and the tracking errors (21) are
only computed when read (:attr:`StepResult.tracking_errors`).
``test/wbc_reference.py`` is an independent numpy/scipy version the tests compare against (1e-9).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from math import cos, isfinite, sin
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from phri_common.planar import base_to_world
from phri_common.records import ContactState
from phri_description.description import BASE_JOINTS
from wholebody_controller.config import ControllerConfig
from wholebody_controller.contact_task import TARGET, ContactTask, TaskOutput
from wholebody_controller.fused import CompiledStep, supports
from wholebody_controller.qp import QPBuilder, QPError, QPProblem, QPSolver, make_solver

Array = NDArray[np.float64]


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

    def link_pose_floats(self, link: str) -> tuple[list[float], list[float]]:
        """:meth:`link_pose` as floats: (⁰R_i row-major, 9; ⁰p_γi, 3)."""
        ...

    def point_jacobian(self, link: str, point: Array, out: Array | None = None) -> Array:
        """6×n world-frame [linear; angular] Jacobian of a point fixed on the link (8), written
        into ``out`` (6×n, C-contiguous) when given, and returned."""
        ...


class StepResult:
    """One control cycle's outcome (read-only by convention).

    Attributes:
        command: u = [v_x, v_y, ω_z (base frame), arm joint velocities] [m/s, rad/s].
        qdot: the same motion as rates of q = [x, y, yaw, arms] (world frame) [m/s, rad/s].
        tasks: per-link task outputs (ψ, phase, deflection, track force …), config order.
        tracking_errors: (21) at the solution, ``b_i − J_i u`` per link [m/s, rad/s]; computed
            on first access (the node reads it only when a task state is subscribed).
        problem: the QP that was solved.
    """

    __slots__ = ("_errors", "_jacobian", "_target", "command", "problem", "qdot", "tasks")

    def __init__(self, command: Array, qdot: Array, tasks: tuple[TaskOutput, ...],
                 problem: QPProblem, target: Array, jacobian: Array) -> None:
        """``target`` (stacked b_i) and ``jacobian`` (stacked J_i in u) are kept, not copied."""
        self.command, self.qdot, self.tasks, self.problem = command, qdot, tasks, problem
        self._target, self._jacobian = target, jacobian
        self._errors: tuple[Array, ...] | None = None

    @property
    def tracking_errors(self) -> tuple[Array, ...]:
        if self._errors is None:
            residual = self._target - self._jacobian @ self.command
            self._errors = tuple(residual.reshape(-1, 6))
        return self._errors

    def __repr__(self) -> str:
        return f"StepResult(command={self.command!r}, tasks={self.tasks!r})"


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
        self._q_shape = (self.n,)
        limits = np.asarray(kinematics.position_limits, dtype=np.float64)
        if np.any(np.isfinite(limits[0:2])):
            raise ValueError("base x/y position limits must be infinite (see module docstring)")
        self._robot_position_limits = limits
        self._robot_velocity_limits = np.asarray(kinematics.velocity_limits, dtype=np.float64)
        self._solver_override = solver
        self.config = ControllerConfig()
        self._tasks: list[ContactTask] = []
        self._compiled: CompiledStep | None = None
        self._rows_stale = False
        self.configure(config or ControllerConfig())

    @property
    def tasks(self) -> list[ContactTask]:
        """The per-link tasks, config order, with their current state. Under the compiled step
        the state lives in its rows: reading this copies it into the task objects, and the next
        step takes the objects' state back (so changes made through them count)."""
        if self._compiled is not None:
            self._compiled.load(self._tasks)
            self._rows_stale = True
        return self._tasks

    def configure(self, config: ControllerConfig) -> None:
        """Apply a new configuration. Tasks whose settings are unchanged keep their state."""
        tasks = self._build_tasks(config)
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
        vmax = config.axis_velocity_limits(self._robot_velocity_limits)
        if self._solver_override is not None:
            self.solver: QPSolver = self._solver_override
        elif getattr(self, "solver", None) is None or self.solver.name != config.solver:
            self.solver = make_solver(config.solver)
        rows = 6 * len(tasks)
        self._rows = rows
        builder = QPBuilder(rows, self.n)
        builder.set_limits(lower, upper, -vmax, vmax, config.horizon, config.epsilon)
        self._builder = builder
        # Jacobian blocks as views (kinematics write into them) and the raw-to-u column map.
        self._raw_jacobian = np.zeros((rows, self.n))
        self._jacobian_blocks = [self._raw_jacobian[6 * i : 6 * i + 6] for i in range(len(tasks))]
        self._task_blocks = [
            (task, task.config.link, block)
            for task, block in zip(tasks, self._jacobian_blocks, strict=True)
        ]
        self._base_rotation = np.eye(self.n)
        self.position_lower, self.position_upper = lower, upper
        self.velocity_upper = vmax
        self.velocity_lower = -vmax
        self._tasks = tasks
        self.config = config
        self._compiled = None
        if config.kernel == "numba" and supports(self.kinematics):
            limits = np.array([lower, upper, -vmax, vmax])
            compiled = CompiledStep(tasks, self.kinematics,
                                    limits, config.horizon, config.epsilon)
            compiled.warm_up()  # compile or load now, not in the first control cycle
            self._compiled = compiled
        self._rows_stale = False

    def _build_tasks(self, config: ControllerConfig) -> list[ContactTask]:
        """One task per configured link; a task whose link settings and task globals are
        unchanged is kept with its state."""
        previous = {task.config.link: task for task in self.tasks}
        same_globals = _task_globals(self.config) == _task_globals(config)
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
                    safety=config.safety, region_window=config.region_window,
                    region_hysteresis=config.region_hysteresis, lead=config.lead_moment,
                )
            )
        return tasks

    def reset(self) -> None:
        """Every task back to inactive (e.g. after stale input)."""
        for task in self._tasks:
            task.reset()
        if self._compiled is not None:
            self._compiled.store(self._tasks)
            self._rows_stale = False

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
        if q.shape != self._q_shape:
            raise ValueError(f"configuration must be {self.n} finite numbers, got {q}")
        q_floats = q.tolist()
        # The sum is finite for every finite q short of overflow; the exact test runs only if not.
        if not isfinite(sum(q_floats)) and not all(map(isfinite, q_floats)):
            raise ValueError(f"configuration must be {self.n} finite numbers, got {q}")
        yaw = q_floats[2]
        if self._compiled is not None:
            return self._step_compiled(self._compiled, q, yaw, contacts)
        kin = self.kinematics
        kin.update(q)
        c, s = cos(yaw), sin(yaw)
        link_pose = kin.link_pose_floats
        point_jacobian = kin.point_jacobian
        targets: list[float] = []
        weights: list[float] = []
        outputs = []
        get = contacts.get
        for task, link, block in self._task_blocks:
            contact = get(link)
            if contact is None:
                contact = task.no_contact
            rot, pos = link_pose(link)
            out = task.step(contact, rot, pos, yaw)
            outputs.append(out)
            targets += out.values[TARGET]
            psi2 = 2.0 * out.psi
            weights += (psi2, psi2, psi2, psi2, psi2, psi2)
            point_jacobian(link, task.jacobian_point, out=block)
        rows = self._rows
        targets += weights
        data = np.array(targets)
        target = data[:rows]
        # World base rates → base-frame twist (module docstring): J_u = J_q · blockdiag(R(yaw), I).
        rotation = self._base_rotation
        rotation[0, 0] = c
        rotation[0, 1] = -s
        rotation[1, 0] = s
        rotation[1, 1] = c
        # Fresh (the result keeps it for its residual); np.dot: less call overhead than @.
        jacobian = np.dot(self._raw_jacobian, rotation)
        problem = self._builder.build(q, target, data[rows:, None], jacobian)
        return self._solve(problem, yaw, tuple(outputs), target, jacobian)

    def _step_compiled(self, compiled: CompiledStep, q: Array, yaw: float,
                       contacts: Mapping[str, ContactState]) -> StepResult:
        """:meth:`step` after the q check, by :mod:`~wholebody_controller.fused`."""
        if self._rows_stale:
            compiled.store(self._tasks)
            self._rows_stale = False
        outputs, target, jacobian, problem, finite = compiled.step(q, contacts)
        if not finite:
            raise QPError("QP data is not finite")
        return self._solve(problem, yaw, outputs, target, jacobian)

    def _solve(self, problem: QPProblem, yaw: float, outputs: tuple[TaskOutput, ...],
               target: Array, jacobian: Array) -> StepResult:
        """Solve (23); the command u and its world-frame rates q̇."""
        command = self.solver.solve(problem)
        u = command.tolist()
        if not isfinite(sum(u)):
            raise QPError("non-finite command")
        u[0], u[1] = base_to_world(yaw, u[0], u[1])
        return StepResult(command, np.array(u), outputs, problem, target, jacobian)


def _task_globals(config: ControllerConfig) -> tuple[object, ...]:
    """The controller-wide settings every :class:`ContactTask` is built from (a change rebuilds
    the tasks)."""
    return (config.k_eta, config.b, config.k_p, config.psi_thr, config.region_margin,
            config.rate_hz, config.safety, config.region_window, config.region_hysteresis,
            config.lead_moment)
