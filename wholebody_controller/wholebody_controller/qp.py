"""The QP (22)–(23): building it is separate from solving it; two solver backends.

Problem (23) with weights Ψ_i = ψ_i I:

    min_u  Σ_i ψ_i ‖J_i u − b_i‖² + ε ‖u‖²
    s.t.   max(q̇_l, (q_l − q)/h) ≤ u ≤ min(q̇_u, (q_u − q)/h)            (22)

is written as ``min ½ uᵀ H u + gᵀ u`` with ``H = 2(Σ ψ_i J_iᵀ J_i + ε I)`` and
``g = −2 Σ ψ_i J_iᵀ b_i`` and box bounds only. When a joint is outside its position range (e.g.
right after q_dance is set) the position bound would demand more than the velocity limit; the
bounds are then clipped into the velocity box, so the joint returns at the velocity limit and the
problem is always feasible.

Backends (same interface, :class:`QPSolver`): :class:`DaqpSolver` (exact dual active set,
default) and :class:`OsqpSolver` (the paper's OSQP [26], warm-started, tolerances
1e-10 so it lands within 1e-6 of the optimum; polishing is off, which also keeps osqp 1.x from
printing "Polishing not needed"). Both clip the answer into the bounds.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from math import isfinite
from typing import Any, NamedTuple, Protocol

import numpy as np
from numpy.typing import NDArray

from phri_common.jit import jitable

Array = NDArray[np.float64]


class QPError(RuntimeError):
    """The QP could not be solved (solver status, non-finite data or answer)."""


class QPProblem(NamedTuple):
    """``min ½ uᵀ H u + gᵀ u`` s.t. ``lower ≤ u ≤ upper`` (immutable)."""

    hessian: Array
    gradient: Array
    lower: Array
    upper: Array

    @property
    def size(self) -> int:
        return int(self.gradient.shape[0])

    def objective(self, u: Array) -> float:
        """½ uᵀ H u + gᵀ u."""
        return float(0.5 * u @ self.hessian @ u + self.gradient @ u)


@jitable
def velocity_bounds_into(q: Array, previous: Array, limits: Array, horizon: float,
                         lower: Array, upper: Array) -> None:
    """The bounds of (23), written into ``lower`` and ``upper``: (22)
    ``clip((q_l − q)/h, q̇_l, q̇_u) ≤ u ≤ clip((q_u − q)/h, q̇_l, q̇_u)``, then both clipped into
    ``previous ± Δ``, the change the actuators can make in one period at their rated
    acceleration (Δ = a·dt). Clipping both bounds into one interval keeps ``lower ≤ upper``;
    where (22) asks for more than the actuators can do in one period (a joint after a q_dance
    change, a lower velocity limit), the command moves towards it at the rated acceleration.

    Args:
        q: current positions [rad] / [m] (only where the position limits are finite).
        previous: the previous command u [m/s, rad/s].
        limits: (5, n) q_l, q_u (±inf allowed), q̇_l ≤ 0 ≤ q̇_u [rad/s] / [m/s], Δ ≥ 0
            [m/s, rad/s] (inf: no acceleration bound).
        horizon: h [s].
    """
    for i in range(q.shape[0]):
        low = min(max((limits[0, i] - q[i]) / horizon, limits[2, i]), limits[3, i])
        high = min(max((limits[1, i] - q[i]) / horizon, limits[2, i]), limits[3, i])
        slowest, fastest = previous[i] - limits[4, i], previous[i] + limits[4, i]
        lower[i] = min(max(low, slowest), fastest)
        upper[i] = min(max(high, slowest), fastest)


LIMIT_ROWS = 8
"""Rows of the controller's bounds array: q_l, q_u, q̇_l, q̇_u, Δ (rated acceleration × dt), then
the yield's: q_l and q_u opened by ``yield_joint_range`` (within the joints' own limits), the
actuator velocity limit (symmetric)."""


@jitable
def yield_limits_into(limits: Array, sigma: float, out: Array) -> None:
    """The bounds of a step in which a link yields with excess scale σ ∈ [0, 1]
    (:mod:`~wholebody_controller.contact_safety`), written into ``out`` (5×n): each of q_l, q_u,
    q̇_l, q̇_u moved the fraction σ of the way from its normal value (rows 0–3 of ``limits``)
    to its yield value (rows 5–7: opened range, actuator velocity); Δ (row 4, the rated
    acceleration × dt) unchanged. An unbounded position limit stays unbounded.

    Args:
        limits: (:data:`LIMIT_ROWS`, n) bounds.
        sigma: σ ∈ [0, 1] (0: ``out`` = rows 0–4).
    """
    for i in range(limits.shape[1]):
        for row, other in ((0, 5), (1, 6)):
            a, b = limits[row, i], limits[other, i]
            out[row, i] = a if a == b else a + sigma * (b - a)
        v = limits[3, i] + sigma * (limits[7, i] - limits[3, i])
        out[2, i], out[3, i] = -v, v
        out[4, i] = limits[4, i]


@jitable
def assemble_qp(jacobian: Array, target: Array, doubled_weights: Array, epsilon: float,
                hessian: Array, gradient: Array) -> bool:
    """(23): ``H = Jᵀ (2Ψ J) + 2ε I`` and ``g = −(2Ψ J)ᵀ b``, written into ``hessian`` and
    ``gradient``; False where H's diagonal or g is not finite (NaN/inf anywhere in J, Ψ or b
    reaches them; an off-diagonal |H_ij| ≤ √(H_ii H_jj) cannot overflow while they do not).

    Args:
        jacobian: stacked task Jacobians J (rows × n) in the decision variable's coordinates.
        target: stacked b_i (rows) [m/s, rad/s].
        doubled_weights: 2ψ_i for each row (rows).
        epsilon: ε > 0.
    """
    rows, n = jacobian.shape
    hessian[:, :] = 0.0
    gradient[:] = 0.0
    for r in range(rows):  # row by row: contiguous, and a link's zero columns are skipped
        w, b = doubled_weights[r], target[r]
        for i in range(n):
            a = w * jacobian[r, i]
            gradient[i] -= b * a
            if a == 0.0:
                continue
            for j in range(i, n):
                hessian[i, j] += a * jacobian[r, j]
    check = 0.0
    for i in range(n):
        for j in range(i + 1, n):
            hessian[j, i] = hessian[i, j]
        hessian[i, i] += 2.0 * epsilon
        check += hessian[i, i] + gradient[i]
    return math.isfinite(check)


def velocity_bounds(
    q: Array,
    position_lower: Array,
    position_upper: Array,
    velocity_lower: Array,
    velocity_upper: Array,
    horizon: float,
) -> tuple[Array, Array]:
    """(22) by :func:`velocity_bounds_into` on new arrays, without an acceleration bound."""
    q = np.asarray(q, dtype=np.float64)
    unbounded = np.full_like(q, np.inf)
    limits = np.array([position_lower, position_upper, velocity_lower, velocity_upper,
                       unbounded], dtype=np.float64)
    lower, upper = np.empty_like(q), np.empty_like(q)
    velocity_bounds_into(q, np.zeros_like(q), limits, float(horizon), lower, upper)
    return lower, upper


def build_qp(
    jacobians: Sequence[Array],
    targets: Sequence[Array],
    weights: Sequence[float],
    epsilon: float,
    lower: Array,
    upper: Array,
) -> QPProblem:
    """(23) from task blocks, by :func:`assemble_qp`.

    Args:
        jacobians: J_i (6×n) of each contact centre, in the decision variable's coordinates
            (blocks may also come pre-stacked: rows are taken in order, 6 per task).
        targets: b_i (6) desired contact-centre velocities [m/s, rad/s], stacked the same way.
        weights: ψ_i ≥ 0, one per 6-row task block.
        epsilon: ε > 0.
        lower, upper: bounds on u (see :func:`velocity_bounds`).

    Raises:
        QPError: non-finite data or inconsistent bounds.
    """
    n = lower.shape[0]
    stacked = np.ascontiguousarray(np.concatenate(jacobians) if len(jacobians)
                                   else np.zeros((0, n)), dtype=np.float64)
    rows = np.repeat(2.0 * np.asarray(weights, dtype=np.float64), 6)
    if rows.shape[0] != stacked.shape[0]:
        raise QPError(f"{len(weights)} weights for {stacked.shape[0]} task rows")
    target = np.concatenate(targets) if len(targets) else np.zeros(0)
    hessian, gradient = np.empty((n, n)), np.empty(n)
    if not assemble_qp(stacked, np.asarray(target, dtype=np.float64), rows, float(epsilon),
                       hessian, gradient):
        raise QPError("QP data is not finite")
    if np.isnan(float(lower.sum()) - float(upper.sum())) or np.any(lower > upper):
        raise QPError(f"QP bounds are inconsistent: lower {lower}, upper {upper}")
    return QPProblem(hessian, gradient, np.asarray(lower, float), np.asarray(upper, float))


def kkt_residual(problem: QPProblem, u: Array) -> float:
    """Optimality residual of a box QP: ‖u − Π(u − ∇f(u))‖_∞ plus bound violation.

    Zero exactly at the optimum (projected-gradient fixed point); independent of any solver.
    """
    grad = problem.hessian @ u + problem.gradient
    projected = np.clip(u - grad, problem.lower, problem.upper)
    violation = np.maximum(problem.lower - u, 0.0) + np.maximum(u - problem.upper, 0.0)
    return float(np.max(np.abs(u - projected)) + np.max(violation))


class QPSolver(Protocol):
    """A QP backend."""

    name: str

    def solve(self, problem: QPProblem) -> Array:
        """Optimal u within the bounds.

        Raises:
            QPError: on failure.
        """
        ...


def _finish(problem: QPProblem, u: Array | None, name: str) -> Array:
    if u is None:
        raise QPError(f"{name} returned no solution")
    x = np.asarray(u, dtype=np.float64)
    # One sum catches NaN/inf (a sum of finite values near the bounds cannot overflow).
    if not isfinite(sum(x.tolist())):
        raise QPError(f"{name} returned a non-finite solution")
    # Clip into the bounds: two ufunc calls instead of np.clip's Python wrapper.
    out = np.maximum(x, problem.lower)
    return np.minimum(out, problem.upper, out=out)


class DaqpSolver:
    """Exact dual active-set solver (daqp), warm-started with the previous active set."""

    name = "daqp"

    def __init__(self) -> None:
        import daqp

        self._daqp = daqp
        self._empty: Array | None = None
        self._sense: NDArray[np.int32] | None = None

    def solve(self, problem: QPProblem) -> Array:
        n = problem.gradient.shape[0]
        if self._empty is None or self._empty.shape[1] != n:
            self._empty = np.zeros((0, n))
            self._sense = np.zeros(n, dtype=np.int32)
        assert self._sense is not None
        # daqp reads bounds beyond the rows of A as simple bounds; infinities are allowed.
        x, _, exitflag, _ = self._daqp.solve(
            problem.hessian, problem.gradient, self._empty, problem.upper, problem.lower,
            self._sense.copy(),
        )
        if exitflag < 1:
            raise QPError(f"daqp failed with exit flag {exitflag}")
        return _finish(problem, x, self.name)


class OsqpSolver:
    """OSQP (ADMM) with warm start and tight tolerances (1e-10 absolute and relative)."""

    name = "osqp"

    def __init__(self, tolerance: float = 1e-10, max_iter: int = 20000) -> None:
        import osqp
        import scipy.sparse as sp

        self._osqp = osqp
        self._sp = sp
        self._tolerance = tolerance
        self._max_iter = max_iter
        self._solver: Any = None
        self._n = -1
        self._rows: NDArray[np.intp] | None = None
        self._cols: NDArray[np.intp] | None = None

    def _setup(self, problem: QPProblem) -> None:
        sp = self._sp
        n = problem.size
        # Full upper-triangular pattern so every later Hessian fits the same sparsity.
        pattern = sp.csc_matrix(np.triu(np.ones((n, n))))
        pattern.sort_indices()
        self._rows = pattern.indices.astype(np.intp)
        self._cols = np.repeat(np.arange(n), np.diff(pattern.indptr)).astype(np.intp)
        p = sp.csc_matrix(
            (problem.hessian[self._rows, self._cols], pattern.indices, pattern.indptr),
            shape=(n, n),
        )
        solver = self._osqp.OSQP()
        solver.setup(
            p, problem.gradient, sp.identity(n, format="csc"),
            problem.lower, problem.upper,
            verbose=False, eps_abs=self._tolerance, eps_rel=self._tolerance,
            eps_prim_inf=1e-12, eps_dual_inf=1e-12,
            polishing=False, warm_starting=True, max_iter=self._max_iter,
        )
        self._solver = solver
        self._n = n

    def solve(self, problem: QPProblem) -> Array:
        if self._solver is None or self._n != problem.size:
            self._setup(problem)
        else:
            assert self._rows is not None and self._cols is not None
            self._solver.update(
                Px=problem.hessian[self._rows, self._cols], q=problem.gradient,
                l=problem.lower, u=problem.upper,
            )
        result = self._solver.solve(raise_error=False)
        if result.info.status_val != self._osqp.SolverStatus.OSQP_SOLVED:
            self._solver = None  # start afresh next time
            raise QPError(f"osqp failed: {result.info.status}")
        return _finish(problem, result.x, self.name)


def make_solver(name: str) -> QPSolver:
    """The backend called ``name`` (``"daqp"`` or ``"osqp"``)."""
    if name == "daqp":
        return DaqpSolver()
    if name == "osqp":
        return OsqpSolver()
    raise ValueError(f"unknown QP solver {name!r}; choose daqp or osqp")
