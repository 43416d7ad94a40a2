"""The whole control step: every link's task (:mod:`task_step`), its contact-centre Jacobian (8)
and the QP (22)–(23). On the robot's MuJoCo kinematics all of it is one function
(:func:`step_robot`); with any other kinematics the controller runs
:func:`~wholebody_controller.task_step.step_links`, the kinematics' ``point_jacobian`` and
:func:`qp_of_step`.

Jacobians. MuJoCo's ``mj_kinematics`` gives the world frames of bodies and joints; the
contact-centre Jacobian (8) is formed from the joint axes and anchors of the link's chain (the
columns ``mj_jac`` would give, without ``mj_comPos``), then turned into the base-frame command u
(:mod:`controller` module docstring). Hinge and slide joints only (the robot's): another model
runs the generic path.

Like :mod:`task_step`, everything here is :func:`jitable` plain Python: ``kernel: numba``
compiles :func:`step_robot` into one call (:mod:`kernels`), ``kernel: python`` runs it as is.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np
from numpy.typing import NDArray

from phri_common.jit import jitable
from wholebody_controller.linalg3 import rotate
from wholebody_controller.qp import assemble_qp, velocity_bounds_into, yield_limits_into
from wholebody_controller.task_rows import N_CONTACT, O_PSI, O_YIELD, S_POINT
from wholebody_controller.task_step import step_task

Array = NDArray[np.float64]
IntArray = NDArray[np.int64]

HINGE, SLIDE = int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE)


def joint_chain(model: mujoco.MjModel, body: int) -> list[tuple[int, int, int]]:
    """(joint id, DOF, type) of every joint between ``body`` and the world, body first."""
    chain = []
    while body > 0:
        first = int(model.body_jntadr[body])
        for joint in range(first, first + int(model.body_jntnum[body])):
            chain.append((joint, int(model.jnt_dofadr[joint]), int(model.jnt_type[joint])))
        body = int(model.body_parentid[body])
    return chain


@jitable
def chain_jacobian(chain: IntArray, xaxis: Array, xanchor: Array, rot: tuple, pos: tuple,
                   point: tuple, c: float, s: float, out: Array) -> None:
    """J_i of (8) in the command u, written into ``out`` (6×n, zeroed here).

    The point ⁰p_η = ⁰R_i ᶦp_η + ⁰p_γi (6) moves with every joint between it and the world
    (``chain`` rows: joint id, its DOF = column, MuJoCo type; −1 rows pad): a hinge of world
    axis a through the anchor o adds ``[a × (⁰p_η − o); a]`` to its column, a slide ``[a; 0]``.
    Then the base columns are rotated by the yaw, (c, s) = (cos, sin): the command's base part
    is a twist in the base frame.
    """
    rx, ry, rz = rotate(rot, point)
    px, py, pz = rx + pos[0], ry + pos[1], rz + pos[2]
    out[:, :] = 0.0
    for row in range(chain.shape[0]):
        joint, col, kind = chain[row, 0], chain[row, 1], chain[row, 2]
        if joint < 0:
            break
        ax, ay, az = xaxis[joint, 0], xaxis[joint, 1], xaxis[joint, 2]
        if kind == HINGE:
            dx, dy, dz = px - xanchor[joint, 0], py - xanchor[joint, 1], pz - xanchor[joint, 2]
            out[0, col], out[1, col], out[2, col] = ay * dz - az * dy, az * dx - ax * dz, \
                ax * dy - ay * dx
            out[3, col], out[4, col], out[5, col] = ax, ay, az
        else:
            out[0, col], out[1, col], out[2, col] = ax, ay, az
    for r in range(6):
        a, b = out[r, 0], out[r, 1]
        out[r, 0] = a * c + b * s
        out[r, 1] = a * -s + b * c


@jitable
def step_robot(state: Array, params: Array, phi_gamma: Array, contacts: Array, xmat: Array,
               xpos: Array, bodies: IntArray, chains: IntArray, xaxis: Array, xanchor: Array,
               q: Array, previous: Array, limits: Array, horizon: float, epsilon: float,
               outputs: Array, target: Array, jacobian: Array, hessian: Array,
               gradient: Array, lower: Array, upper: Array) -> bool:
    """One control step of every link after ``mj_kinematics``: the tasks, their Jacobians and
    (22)–(23).

    Args:
        state, params: (k, N_STATE), (k, N_PARAM) task rows (state updated).
        phi_gamma: (k, 12, 18) ``[Φ Γ]`` of each admittance (13).
        contacts: this cycle's contact rows (link frame), N_CONTACT floats per link.
        xmat, xpos: MuJoCo's world frames of the bodies (nbody×9, nbody×3).
        bodies: body id of each link; chains: (k, L, 3) each link's :func:`joint_chain`.
        xaxis, xanchor: MuJoCo's world joint axes and anchors (njnt×3).
        q: configuration (n) [m, rad]; previous: the previous command u (n);
            limits: (8, n) q_l, q_u, q̇_l, q̇_u, a·dt (:func:`velocity_bounds_into`) and the
            yield's (:func:`~wholebody_controller.qp.yield_limits_into`);
            horizon h [s]; epsilon ε of (23).
        outputs, target, jacobian, hessian, gradient, lower, upper: written: the tasks' rows
            (k, N_OUT), b (6k), J in u (6k×n), H (n×n), g (n), the bounds (n each).

    Returns:
        Whether H's diagonal and g are finite.
    """
    yaw = q[2]
    c, s = math.cos(yaw), math.sin(yaw)
    for i in range(state.shape[0]):
        body = bodies[i]
        m, p = xmat[body], xpos[body]
        rot = (m[0], m[1], m[2], m[3], m[4], m[5], m[6], m[7], m[8])
        pos = (p[0], p[1], p[2])
        step_task(state[i], params[i], phi_gamma[i],
                  contacts[N_CONTACT * i : N_CONTACT * (i + 1)], rot, pos, yaw, outputs[i])
        point = (state[i, S_POINT], state[i, S_POINT + 1], state[i, S_POINT + 2])
        chain_jacobian(chains[i], xaxis, xanchor, rot, pos, point, c, s,
                       jacobian[6 * i : 6 * i + 6])
    return qp_of_step(outputs, jacobian, q, previous, limits, horizon, epsilon, target,
                      hessian, gradient, lower, upper)


@jitable
def qp_of_step(outputs: Array, jacobian: Array, q: Array, previous: Array, limits: Array,
               horizon: float, epsilon: float, target: Array, hessian: Array, gradient: Array,
               lower: Array, upper: Array) -> bool:
    """(22)–(23) of a step: the targets b_i and weights ψ_i from the tasks' output rows
    (k × N_OUT), J (6k × n, in u), bounds from q, the previous command and ``limits`` (8×n:
    q_l, q_u, q̇_l, q̇_u, a·dt, then the yield's), h and ε; writes ``target``, ``hessian``,
    ``gradient``, ``lower``, ``upper``. While a link yields, the bounds are opened by the
    largest excess scale σ of the tasks (:func:`~wholebody_controller.qp.yield_limits_into`).
    Returns whether H's diagonal and g are finite."""
    k = outputs.shape[0]
    weights = np.empty(6 * k)
    sigma = 0.0
    for i in range(k):
        psi2 = 2.0 * outputs[i, O_PSI]
        sigma = max(sigma, outputs[i, O_YIELD])
        for r in range(6):
            target[6 * i + r] = outputs[i, r]
            weights[6 * i + r] = psi2
    bounds = limits
    if sigma > 0.0:
        bounds = np.empty((5, limits.shape[1]))
        yield_limits_into(limits, sigma, bounds)
    velocity_bounds_into(q, previous, bounds, horizon, lower, upper)
    return assemble_qp(jacobian, target, weights, epsilon, hessian, gradient)
