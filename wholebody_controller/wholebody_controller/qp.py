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
default — ≈ 10 µs here) and :class:`OsqpSolver` (the paper's OSQP [26], warm-started, tolerances
1e-10 so it lands within 1e-6 of the optimum; polishing is off, which also keeps osqp 1.x from
printing "Polishing not needed"). Both clip the answer into the bounds.
"""

from __future__ import annotations

from collections.abc import Sequence
from math import isfinite
from typing import Any, NamedTuple, Protocol

import numpy as np
from numpy.typing import NDArray

Array = NDArray[np.float64]


_dot = np.dot
# QPProblem(...) without the Python-level __new__ of a NamedTuple (hot path).
_new_tuple = tuple.__new__


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


def velocity_bounds(
    q: Array,
    position_lower: Array,
    position_upper: Array,
    velocity_lower: Array,
    velocity_upper: Array,
    horizon: float,
) -> tuple[Array, Array]:
    """Bounds of (23) from (22), clipped into the velocity box so they are always consistent.

    Args:
        q: current positions [rad] / [m] (only where the position bounds are finite).
        position_lower, position_upper: q_l, q_u (±inf allowed).
        velocity_lower, velocity_upper: q̇_l ≤ 0 ≤ q̇_u [rad/s] / [m/s].
        horizon: h [s].
    """
    with np.errstate(invalid="ignore"):
        lower = np.clip((position_lower - q) / horizon, velocity_lower, velocity_upper)
        upper = np.clip((position_upper - q) / horizon, velocity_lower, velocity_upper)
    return lower, upper


def build_qp(
    jacobians: Sequence[Array],
    targets: Sequence[Array],
    weights: Sequence[float],
    epsilon: float,
    lower: Array,
    upper: Array,
) -> QPProblem:
    """Assemble (23).

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
    stacked = np.concatenate(jacobians) if len(jacobians) else np.zeros((0, n))
    rows = np.repeat(np.asarray(weights, dtype=np.float64), 6)
    if rows.shape[0] != stacked.shape[0]:
        raise QPError(f"{len(weights)} weights for {stacked.shape[0]} task rows")
    weighted = stacked.T * rows  # Jᵀ Ψ
    hessian = 2.0 * (weighted @ stacked)
    hessian.flat[:: n + 1] += 2.0 * epsilon
    gradient = -2.0 * (weighted @ np.concatenate(targets)) if len(targets) else np.zeros(n)
    # One scalar reduction catches NaN/inf anywhere in the data.
    if not np.isfinite(float(hessian.sum()) + float(gradient.sum())):
        raise QPError("QP data is not finite")
    if np.isnan(float(lower.sum()) - float(upper.sum())) or np.any(lower > upper):
        raise QPError(f"QP bounds are inconsistent: lower {lower}, upper {upper}")
    return QPProblem(hessian, gradient, lower, upper)


class QPBuilder:
    """:func:`velocity_bounds` + :func:`build_qp` for a fixed problem size, for the control step.

    Same problem, fewer numpy calls: the stacked Jacobian lives in :attr:`jacobian` (the caller
    writes the task blocks into it in place), ``H = 2 Jᵀ (Ψ J) + 2ε I`` and ``g = −2 (Ψ J)ᵀ b``
    are two matrix products on it, and both bound vectors come from one broadcast over a 2×n
    table. The hessian, gradient and bounds of every :class:`QPProblem` are fresh arrays (a
    result never changes after it is returned); only the scratch buffers are reused.

    Args:
        rows: task rows (6 per task).
        n: decision variables.
    """

    def __init__(self, rows: int, n: int) -> None:
        self.rows, self.n = rows, n
        self.jacobian = np.zeros((rows, n))
        """Stacked task Jacobians in the decision variable's coordinates (written by the caller)."""
        self._weighted = np.zeros((rows, n))
        self._eps_eye = np.zeros((n, n))
        self._position = np.zeros((2, n))
        self._velocity_lower = np.zeros((2, n))
        self._velocity_upper = np.zeros((2, n))
        self._horizon = 1.0

    def set_limits(
        self,
        position_lower: Array,
        position_upper: Array,
        velocity_lower: Array,
        velocity_upper: Array,
        horizon: float,
        epsilon: float,
    ) -> None:
        """Limits of (22) (see :func:`velocity_bounds`) and ε of (23).

        Raises:
            ValueError: ``position_lower > position_upper`` or ``velocity_lower > velocity_upper``
                somewhere (the per-step bounds are then consistent by construction).
        """
        if np.any(position_lower > position_upper) or np.any(velocity_lower > velocity_upper):
            raise ValueError("QP limits need lower ≤ upper")
        self._position[0], self._position[1] = position_lower, position_upper
        self._velocity_lower[:] = velocity_lower
        self._velocity_upper[:] = velocity_upper
        self._horizon = float(horizon)
        self._eps_eye[...] = np.diag(np.full(self.n, 2.0 * epsilon))

    def build(
        self, q: Array, target: Array, doubled_weights: Array, jacobian: Array | None = None
    ) -> QPProblem:
        """(23) at configuration q.

        Args:
            q: positions (n) [rad] / [m].
            target: stacked b_i (rows) [m/s, rad/s].
            doubled_weights: 2ψ_i for each row, shape (rows, 1) (the 2 of ``H = 2(…)``
                folded in, which saves a pass over H).
            jacobian: stacked task Jacobians (rows×n); default :attr:`jacobian`.

        Raises:
            QPError: non-finite data.
        """
        jac = self.jacobian if jacobian is None else jacobian
        weighted = np.multiply(jac, doubled_weights, out=self._weighted)  # 2Ψ J
        # np.dot: the same products with less call overhead than @ at this size.
        hessian = _dot(jac.T, weighted)
        gradient = target.dot(weighted)
        hessian += self._eps_eye
        np.negative(gradient, out=gradient)
        # NaN/inf anywhere in J, Ψ or b reaches g (0·inf = NaN included) and the diagonal of H;
        # an off-diagonal |H_ij| ≤ √(H_ii H_jj) cannot overflow while the diagonal does not. Sums
        # of Python floats: cheaper than two numpy reductions at this size.
        if not isfinite(sum(hessian.diagonal().tolist()) + sum(gradient.tolist())):
            raise QPError("QP data is not finite")
        # (22): clip((q_l − q)/h, q̇_l, q̇_u) ≤ u ≤ clip((q_u − q)/h, q̇_l, q̇_u). The limits are
        # ordered (set_limits) and monotone maps keep the order, so lower ≤ upper always.
        bounds = np.subtract(self._position, q)
        np.divide(bounds, self._horizon, out=bounds)
        np.maximum(bounds, self._velocity_lower, out=bounds)
        np.minimum(bounds, self._velocity_upper, out=bounds)
        lower, upper = bounds
        return _new_tuple(QPProblem, (hessian, gradient, lower, upper))


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
