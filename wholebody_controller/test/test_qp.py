"""QP (22)–(23): both backends against an independent bounded least-squares solve (scipy BVLS),
KKT residual, bounds, and failure reporting."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.optimize import lsq_linear

from wholebody_controller.qp import (
    DaqpSolver,
    OsqpSolver,
    QPError,
    QPProblem,
    build_qp,
    kkt_residual,
    make_solver,
    velocity_bounds,
)

N = 15


def random_problem(seed: int) -> tuple[QPProblem, list[np.ndarray], list[np.ndarray],
                                       list[float], float]:
    rng = np.random.default_rng(seed)
    jacobians = [rng.normal(size=(6, N)) for _ in range(3)]
    targets = [rng.normal(scale=0.3, size=6) for _ in range(3)]
    weights = [float(w) for w in rng.choice([1e-4, 0.05, 0.5, 1.0], size=3)]
    q = rng.uniform(-2.0, 2.0, N)
    pos_lo = np.where(rng.random(N) < 0.3, -np.inf, q - rng.uniform(0.0, 0.05, N))
    pos_hi = np.where(rng.random(N) < 0.3, np.inf, q + rng.uniform(0.0, 0.05, N))
    vmax = rng.uniform(0.05, 0.3, N)
    lower, upper = velocity_bounds(q, pos_lo, pos_hi, -vmax, vmax, 0.15)
    eps = float(rng.choice([1e-3, 0.1]))
    problem = build_qp(jacobians, targets, weights, eps, lower, upper)
    return problem, jacobians, targets, weights, eps


def reference_solution(jacobians: list[np.ndarray], targets: list[np.ndarray],
                       weights: list[float], eps: float, lower: np.ndarray,
                       upper: np.ndarray) -> np.ndarray:
    # (23) as a bounded linear least-squares problem: stack √ψ_i J_i and √ε I.
    a = np.vstack([np.sqrt(w) * j for w, j in zip(weights, jacobians, strict=True)]
                  + [np.sqrt(eps) * np.eye(N)])
    b = np.concatenate([np.sqrt(w) * t for w, t in zip(weights, targets, strict=True)]
                       + [np.zeros(N)])
    return lsq_linear(a, b, bounds=(lower, upper), method="bvls", tol=1e-15).x


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**31 - 1))
def test_backends_match_independent_reference(seed: int) -> None:
    problem, jacs, targets, weights, eps = random_problem(seed)
    ref = reference_solution(jacs, targets, weights, eps, problem.lower, problem.upper)
    for solver in (DaqpSolver(), OsqpSolver()):
        u = solver.solve(problem)
        assert np.max(np.abs(u - ref)) < 1e-6, solver.name
        assert kkt_residual(problem, u) < 1e-7, solver.name
        assert np.all(u >= problem.lower) and np.all(u <= problem.upper)


def test_osqp_warm_start_stays_accurate_over_a_changing_sequence() -> None:
    osqp_solver, daqp_solver = OsqpSolver(), DaqpSolver()
    for seed in range(40):
        problem = random_problem(seed)[0]
        assert np.max(np.abs(osqp_solver.solve(problem) - daqp_solver.solve(problem))) < 1e-6


def test_osqp_prints_nothing(capfd: pytest.CaptureFixture[str]) -> None:
    solver = OsqpSolver()
    for seed in range(3):
        solver.solve(random_problem(seed)[0])
    out, err = capfd.readouterr()
    assert out == "" and err == ""


def test_unconstrained_optimum_is_the_regularised_least_squares() -> None:
    rng = np.random.default_rng(3)
    jac, target = rng.normal(size=(6, N)), rng.normal(size=6)
    inf = np.full(N, np.inf)
    problem = build_qp([jac], [target], [0.7], 0.1, -inf, inf)
    expected = np.linalg.solve(0.7 * jac.T @ jac + 0.1 * np.eye(N), 0.7 * jac.T @ target)
    for name in ("daqp", "osqp"):
        np.testing.assert_allclose(make_solver(name).solve(problem), expected, atol=1e-8)


def test_bounds_from_horizon_and_out_of_range_joints() -> None:
    q = np.array([0.0, 0.99, 1.5, -1.5])
    lo, hi = velocity_bounds(q, np.full(4, -1.0), np.full(4, 1.0), np.full(4, -0.15),
                             np.full(4, 0.15), 0.15)
    # Far from limits: velocity box; 1 cm from the upper: (1 − 0.99)/0.15.
    np.testing.assert_allclose(lo[:2], [-0.15, -0.15])
    np.testing.assert_allclose(hi[:2], [0.15, 0.01 / 0.15])
    # Outside the range: forced back at the velocity limit, never infeasible.
    np.testing.assert_allclose([lo[2], hi[2]], [-0.15, -0.15])
    np.testing.assert_allclose([lo[3], hi[3]], [0.15, 0.15])


def test_bad_data_raises_qp_error() -> None:
    jac = np.ones((6, N))
    target = np.full(6, np.nan)
    inf = np.full(N, np.inf)
    with pytest.raises(QPError):
        build_qp([jac], [target], [1.0], 0.1, -inf, inf)
    with pytest.raises(QPError):
        build_qp([jac], [np.zeros(6)], [1.0], 0.1, np.ones(N), np.zeros(N))
    with pytest.raises(ValueError, match="unknown QP solver"):
        make_solver("cvxopt")
