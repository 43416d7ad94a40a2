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

State. Each link's task state is one row of :attr:`WholeBodyController.state`
(:mod:`task_rows`), stepped by the one implementation of the step (:mod:`task_step`,
:mod:`whole_step`) through the configured kernel (:mod:`kernels`: compiled or interpreted, the
same functions). On the robot's MuJoCo kinematics the whole step is one kernel call
(:func:`~wholebody_controller.whole_step.step_robot`); any other kinematics (a test robot, a
model with other joint types) runs the tasks, its own ``point_jacobian`` and the QP assembly in
turn. :attr:`WholeBodyController.tasks` gives read-only handles on the rows
(:class:`~wholebody_controller.tasks.ContactTask`). The tracking errors (21) are only computed
when read (:attr:`StepResult.tracking_errors`). ``test/wbc_reference.py`` is an independent
numpy/scipy version of the whole step the tests compare against (1e-9).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from math import cos, isfinite, sin
from typing import Protocol

import mujoco
import numpy as np
from numpy.typing import NDArray

from phri_common.planar import base_to_world
from phri_common.records import ContactState
from phri_description.description import BASE_JOINTS
from wholebody_controller.config import ControllerConfig
from wholebody_controller.contact_task import TaskOutput
from wholebody_controller.kernels import StepKernel, step_kernel
from wholebody_controller.kinematics import RobotKinematics
from wholebody_controller.qp import QPError, QPProblem, QPSolver, make_solver
from wholebody_controller.task_rows import (
    N_CONTACT,
    N_OUT,
    N_STATE,
    S_POINT,
    contact_rows,
    link_params,
    task_outputs,
)
from wholebody_controller.tasks import ContactTask, admittance_transition
from wholebody_controller.whole_step import HINGE, SLIDE, joint_chain

Array = NDArray[np.float64]
IntArray = NDArray[np.int64]


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
        limits = np.asarray(kinematics.position_limits, dtype=np.float64)
        if np.any(np.isfinite(limits[0:2])):
            raise ValueError("base x/y position limits must be infinite (see module docstring)")
        self._robot_position_limits = limits
        self._robot_velocity_limits = np.asarray(kinematics.velocity_limits, dtype=np.float64)
        self._solver_override = solver
        self._robot = RobotFrames.of(kinematics)
        self.config = ControllerConfig(links=())
        self.links: tuple[str, ...] = ()
        self.state = np.zeros((0, N_STATE))
        """One state row per link (:mod:`task_rows`), config order: the tasks' whole state."""
        self.previous_command = np.zeros(self.n)
        """The last command u returned by :meth:`step` (zero after :meth:`reset`): each command
        stays within the rated acceleration of it."""
        self.params = np.zeros((0, 0))
        self.phi_gamma = np.zeros((0, 12, 18))
        self.configure(config or ControllerConfig())

    @property
    def tasks(self) -> tuple[ContactTask, ...]:
        """Handles on the per-link task rows, config order (reading them changes nothing)."""
        return tuple(ContactTask(link, self.config, state=self.state[i], params=self.params[i],
                                 phi_gamma=self.phi_gamma[i])
                     for i, link in enumerate(self.config.links))

    def configure(self, config: ControllerConfig) -> None:
        """Apply a new configuration. A link whose parameters and admittance are unchanged keeps
        its task state; a changed or new one starts inactive."""
        params = np.array([link_params(link, config) for link in config.links]
                          ).reshape(len(config.links), -1)
        phi_gamma = np.array([admittance_transition(link, config) for link in config.links]
                             ).reshape(len(config.links), 12, 18)
        state = np.zeros((len(config.links), N_STATE))
        previous = {link: i for i, link in enumerate(self.links)}
        for i, link in enumerate(config.links):
            j = previous.get(link.link)
            if j is not None and np.array_equal(self.params[j], params[i], equal_nan=True) \
                    and np.array_equal(self.phi_gamma[j], phi_gamma[i]):
                state[i] = self.state[j]
        self.limits = self._limits(config)
        if self._solver_override is not None:
            self.solver: QPSolver = self._solver_override
        elif getattr(self, "solver", None) is None or self.solver.name != config.solver:
            self.solver = make_solver(config.solver)
        self.kernel: StepKernel = step_kernel(config.kernel)
        self.state, self.params, self.phi_gamma = state, params, phi_gamma
        self.config, self.links = config, tuple(link.link for link in config.links)
        k = len(self.links)
        self._outputs = np.zeros((k, N_OUT))
        self._raw_jacobian = np.zeros((6 * k, self.n))
        self._base_rotation = np.eye(self.n)
        self._bodies = self._chains = None
        if self._robot is not None:
            self._bodies, self._chains = self._robot.chains(self.links)
            self._warm_up()

    def _limits(self, config: ControllerConfig) -> Array:
        """(8, n): q_l, q_u (the joints' own, within ``joint_ranges``), q̇_l, q̇_u of (22), the
        largest change of each command in one period (rated acceleration × dt), then the
        yield's (:func:`~wholebody_controller.qp.yield_limits_into`): the arm joints' ranges
        opened by ``yield_joint_range`` within their own limits, their actuator velocity limit
        (``velocity_limits`` and the robot's, without Table II's ``velocity_limit``); the base's
        bounds stay the normal ones. The acceleration bound stays the rated one throughout."""
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
        self.position_lower, self.position_upper = lower, upper
        self.velocity_lower, self.velocity_upper = -vmax, vmax
        rated = np.asarray(config.acceleration_limits, dtype=np.float64)
        if rated.shape != (self.n,):
            raise ValueError(f"parameter 'acceleration_limits' has {rated.size} entries, the "
                             f"robot {self.n} axes (base x, y, yaw, arms)")
        opened = config.safety.yield_joint_range
        robot_lower, robot_upper = self._robot_position_limits.T
        yield_lower, yield_upper = lower.copy(), upper.copy()
        yield_lower[3:] = np.maximum(robot_lower[3:], lower[3:] - opened)
        yield_upper[3:] = np.minimum(robot_upper[3:], upper[3:] + opened)
        actuator = np.minimum(self._robot_velocity_limits,
                              np.asarray(config.velocity_limits, dtype=np.float64))
        actuator = np.maximum(actuator, vmax)
        # The base keeps its normal bounds: a fast base turn sweeps the other arm through the
        # partner (docs: Contact safety, "The yield is graded").
        actuator[:3] = vmax[:3]
        return np.ascontiguousarray(
            [lower, upper, -vmax, vmax, rated * config.dt, yield_lower, yield_upper, actuator],
            dtype=np.float64)

    def _warm_up(self) -> None:
        """Run the kernel once on scratch copies: compiles (or loads) it now, not in the first
        control cycle."""
        saved = self.state.copy()
        try:
            self._step_robot(np.zeros(self.n), np.zeros(len(self.links) * N_CONTACT))
        finally:
            self.state[...] = saved

    def reset(self) -> None:
        """Every task back to inactive and the robot taken as stopped (the node sends zero on
        stale input, a QP failure, a refused input: the next command ramps up from rest)."""
        self.state[...] = 0.0
        self.previous_command[...] = 0.0

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
        if q.shape != (self.n,):
            raise ValueError(f"configuration must be {self.n} finite numbers, got {q}")
        q_floats = q.tolist()
        # The sum is finite for every finite q short of overflow; the exact test runs only if not.
        if not isfinite(sum(q_floats)) and not all(map(isfinite, q_floats)):
            raise ValueError(f"configuration must be {self.n} finite numbers, got {q}")
        rows, touched = contact_rows(self.links, contacts)
        if self._robot is not None:
            problem, target, jacobian, finite = self._step_robot(q, rows)
        else:
            problem, target, jacobian, finite = self._step_generic(q, rows)
        if not finite:
            raise QPError("QP data is not finite")
        outputs = task_outputs(self.links, self._outputs, touched)
        return self._solve(problem, q_floats[2], outputs, target, jacobian)

    def _step_robot(self, q: Array, rows: Array) -> tuple[QPProblem, Array, Array, bool]:
        """The whole step in one kernel call on the MuJoCo frames at q."""
        robot = self._robot
        assert robot is not None
        robot.update(q)
        rows_n, n = 6 * len(self.links), self.n
        empty = np.empty
        target, jacobian = empty(rows_n), empty((rows_n, n))
        hessian, gradient, lower, upper = empty((n, n)), empty(n), empty(n), empty(n)
        finite = self.kernel.step_robot(
            self.state, self.params, self.phi_gamma, rows, robot.data.xmat, robot.data.xpos,
            self._bodies, self._chains, robot.data.xaxis, robot.data.xanchor, q,
            self.previous_command, self.limits, self.config.horizon, self.config.epsilon,
            self._outputs, target, jacobian, hessian, gradient, lower, upper)
        return QPProblem(hessian, gradient, lower, upper), target, jacobian, bool(finite)

    def _step_generic(self, q: Array, rows: Array) -> tuple[QPProblem, Array, Array, bool]:
        """The tasks, the kinematics' own Jacobians (8), then the QP (any kinematics)."""
        kin = self.kinematics
        kin.update(q)
        frames = [kin.link_pose_floats(link) for link in self.links]
        rots = np.array([f[0] for f in frames]).reshape(-1, 9)
        positions = np.array([f[1] for f in frames]).reshape(-1, 3)
        yaw = float(q[2])
        self.kernel.step_links(self.state, self.params, self.phi_gamma, rows, rots, positions,
                               yaw, self._outputs)
        for i, link in enumerate(self.links):
            kin.point_jacobian(link, self.state[i, S_POINT : S_POINT + 3].copy(),
                               out=self._raw_jacobian[6 * i : 6 * i + 6])
        # World base rates → base-frame twist (module docstring): J_u = J_q · blockdiag(R, I).
        c, s = cos(yaw), sin(yaw)
        rotation = self._base_rotation
        rotation[0, 0], rotation[0, 1], rotation[1, 0], rotation[1, 1] = c, -s, s, c
        jacobian = np.dot(self._raw_jacobian, rotation)
        n, rows_n = self.n, 6 * len(self.links)
        target = np.empty(rows_n)
        hessian, gradient, lower, upper = (np.empty((n, n)), np.empty(n), np.empty(n),
                                           np.empty(n))
        finite = self.kernel.qp_of_step(self._outputs, jacobian, q, self.previous_command,
                                        self.limits, self.config.horizon, self.config.epsilon,
                                        target, hessian, gradient, lower, upper)
        return QPProblem(hessian, gradient, lower, upper), target, jacobian, bool(finite)

    def _solve(self, problem: QPProblem, yaw: float, outputs: tuple[TaskOutput, ...],
               target: Array, jacobian: Array) -> StepResult:
        """Solve (23); the command u and its world-frame rates q̇."""
        command = self.solver.solve(problem)
        u = command.tolist()
        if not isfinite(sum(u)):
            raise QPError("non-finite command")
        self.previous_command[...] = command
        u[0], u[1] = base_to_world(yaw, u[0], u[1])
        return StepResult(command, np.array(u), outputs, problem, target, jacobian)


class RobotFrames:
    """The MuJoCo side of :func:`~wholebody_controller.whole_step.step_robot`: a
    ``RobotKinematics`` whose MuJoCo positions and DOFs are q itself (the default model), with
    hinge and slide joints only."""

    def __init__(self, kinematics: RobotKinematics) -> None:
        self.kinematics = kinematics
        self.model, self.data = kinematics.model, kinematics.data
        self._qpos = kinematics.data.qpos

    @classmethod
    def of(cls, kinematics: object) -> RobotFrames | None:
        """Frames for ``kinematics`` if the one-call step can drive it, else None."""
        if not isinstance(kinematics, RobotKinematics) or not kinematics.dofs_are_q:
            return None
        kinds = kinematics.model.jnt_type
        if not np.all((kinds == HINGE) | (kinds == SLIDE)):
            return None
        return cls(kinematics)

    def chains(self, links: Sequence[str]) -> tuple[IntArray, IntArray]:
        """Body ids of ``links`` and their joint chains ((k, L, 3), padded with −1 rows)."""
        bodies = np.array([self.kinematics.body_id(link) for link in links], dtype=np.int64)
        chains = [joint_chain(self.model, int(body)) for body in bodies]
        out = np.full((len(links), max(map(len, chains), default=0), 3), -1, dtype=np.int64)
        for i, chain in enumerate(chains):
            out[i, : len(chain)] = chain
        return bodies, out

    def update(self, q: Array) -> None:
        """MuJoCo's frames at q (finite, checked by the caller)."""
        self._qpos[:] = q
        mujoco.mj_kinematics(self.model, self.data)
