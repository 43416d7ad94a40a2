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
numpy call costs as much as dozens of float operations, so the step makes few of them: the tasks
run on plain floats (:meth:`ContactTask.advance`), their outputs stay floats until read
(:class:`TaskOutput`), targets and weights of all tasks become one array, the Jacobians are
written in place into one stacked buffer (``point_jacobian(..., out=)`` when the kinematics
offers it), the base-frame rotation is one product with a 15×15 matrix, and
:class:`~wholebody_controller.qp.QPBuilder` forms H and g with two products.
``test/wbc_reference.py`` is the straightforward version the tests compare against (1e-9).
"""

from __future__ import annotations

import inspect
import math
from collections.abc import Mapping, Sequence
from typing import NamedTuple, Protocol

import numpy as np
from numpy.typing import NDArray

from phri_common.contact import ContactState
from wholebody_controller.config import ControllerConfig
from wholebody_controller.contact_task import TARGET, ContactTask, TaskOutput
from wholebody_controller.qp import QPBuilder, QPError, QPProblem, QPSolver, make_solver

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


class StepResult(NamedTuple):
    """One control cycle's outcome (immutable).

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
    vx, vy = qdot[0:2].tolist()
    qdot[0] = c * vx - s * vy
    qdot[1] = s * vx + c * vy
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
        # point_jacobian(link, point, out=) writes in place (RobotKinematics); optional.
        try:
            params = inspect.signature(kinematics.point_jacobian).parameters
        except (TypeError, ValueError):
            params = {}  # type: ignore[assignment]
        self._jacobian_out = "out" in params
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
        rows = 6 * len(tasks)
        builder = QPBuilder(rows, self.n)
        builder.set_limits(lower, upper, -vmax, vmax, config.horizon, config.epsilon)
        self._builder = builder
        # Jacobian blocks as views (kinematics write into them) and the raw-to-u column map.
        self._raw_jacobian = np.zeros((rows, self.n))
        self._jacobian_blocks = [self._raw_jacobian[6 * i : 6 * i + 6] for i in range(len(tasks))]
        self._base_rotation = np.eye(self.n)
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
        # q·q is finite for every finite q short of overflow; the exact test only runs otherwise.
        if q.shape != (self.n,) or (
            not math.isfinite(float(q @ q)) and not bool(np.all(np.isfinite(q)))
        ):
            raise ValueError(f"configuration must be {self.n} finite numbers, got {q}")
        kin = self.kinematics
        kin.update(q)
        yaw = float(q[2])
        c, s = math.cos(yaw), math.sin(yaw)
        thr = self.config.psi_thr
        jacobian_out = self._jacobian_out
        targets: list[float] = []
        weights: list[float] = []
        outputs = []
        for task, block in zip(self.tasks, self._jacobian_blocks, strict=True):
            link = task.config.link
            contact = contacts.get(link)
            if contact is None:
                contact = task.no_contact
            rot, pos = kin.link_pose(link)
            step = task.advance(contact, rot.ravel().tolist(), pos.tolist(), c, s)
            psi = step.psi_raw if step.psi_raw > thr else thr
            outputs.append(TaskOutput.from_values(link, step.phase, psi, step.psi_raw,
                                                  step.in_contact, step.values))
            targets += step.values[TARGET]
            weights += [2.0 * psi] * 6
            if jacobian_out:
                kin.point_jacobian(link, task.point_array, out=block)  # type: ignore[call-arg]
            else:
                block[...] = kin.point_jacobian(link, task.point_array)
        count = len(outputs)
        data = np.array(targets + weights).reshape(2, 6 * count)
        target = data[0]
        doubled_weights = data[1].reshape(-1, 1)
        # World base rates → base-frame twist (module docstring): J_u = J_q · blockdiag(R(yaw), I).
        rotation = self._base_rotation
        rotation[0, 0] = c
        rotation[0, 1] = -s
        rotation[1, 0] = s
        rotation[1, 1] = c
        builder = self._builder
        jacobian = builder.jacobian
        np.matmul(self._raw_jacobian, rotation, out=jacobian)
        problem = builder.build(q, target, doubled_weights)
        command = self.solver.solve(problem)
        if not math.isfinite(float(command.sum())):
            raise QPError("non-finite command")
        residual = target - jacobian @ command
        return StepResult(
            command=command,
            qdot=base_command_to_rates(command, yaw),
            tasks=tuple(outputs),
            tracking_errors=tuple(residual.reshape(count, 6)),
            problem=problem,
        )
