"""The compiled control step (numba): all contact tasks, their Jacobians and the QP in one call.

What :meth:`WholeBodyController.step` does per link in Python — Algorithm 1 around (8),
(10)–(20) with the contact safety of :mod:`~wholebody_controller.contact_safety`
(:meth:`ContactTask.step`), the contact-centre Jacobian (8) — and then the QP build (22)–(23)
(:class:`~wholebody_controller.qp.QPBuilder`), compiled into one machine-code call
(:func:`step_kernel`). The controller selects it with ``kernel="numba"`` (the default); the
Python code stays the readable reference and the tests' oracle (``test_fused.py`` compares the
two step by step on randomized sequences, every phase and safety path).

One implementation per formula: the equations are *not* rewritten here. The pure float functions
of :mod:`so3`, :mod:`linalg3`, :mod:`contact_task`, :mod:`region`, :mod:`following` and
:mod:`contact_safety` are compiled as they are (``register_jitable``: they stay plain Python for
the reference path). Only the bookkeeping of the task objects (their state) is mirrored, on one
float row per link (layout ``S_*`` below), with the task parameters on another (``P_*``).

Jacobians. MuJoCo's ``mj_kinematics`` gives the world frames of bodies and joints; the kernel
forms the contact-centre Jacobian (8) from the joint axes and anchors of the link's chain (the
columns ``mj_jac`` would give, without ``mj_comPos`` and three more calls), then turns it into
the base-frame command u (``controller`` module docstring). Hinge and slide joints only (the
robot's); another model runs the Python step (:func:`supports`).

Cache: compiled with ``cache=True`` (the machine code is stored next to this module and loaded
by later processes: a controller configures in well under a second once it has run once, about
20 s the first time; ``configure`` warms it up, never the first control cycle). numba checks the
time stamp of this file only, not of the modules whose functions it compiles in, so
:func:`_drop_stale_cache` deletes this module's cache whenever their source changed.
"""

from __future__ import annotations

import hashlib
import inspect
import math
from collections.abc import Mapping, Sequence
from pathlib import Path

import mujoco
import numpy as np
from numba import njit
from numba.extending import register_jitable
from numpy.typing import NDArray

from phri_common import planar
from phri_common.records import ContactState
from wholebody_controller import contact_safety, contact_task, following, linalg3, region, so3
from wholebody_controller.contact_safety import Safety, approach_scale, limit_approach
from wholebody_controller.contact_task import (
    ContactTask,
    Phase,
    TaskOutput,
    contact_rate,
    contact_wrench,
    desired_orientation,
    priority,
    sliding_terms,
    task_velocity,
)
from wholebody_controller.following import lead_moment, leash_reference
from wholebody_controller.kinematics import RobotKinematics
from wholebody_controller.linalg3 import rotate
from wholebody_controller.qp import QPProblem
from wholebody_controller.region import gated_track_force, grow_box, track_force

Array = NDArray[np.float64]

for _module, _names in (
    (so3, ("coefficients", "exp_and_left_jacobian", "exp", "log", "_log_near_pi")),
    (linalg3, ("rotate", "rotate_pair", "matmul", "matmul_transpose")),
    (contact_task, ("contact_rate", "contact_wrench", "priority", "desired_orientation",
                    "task_velocity", "sliding_terms")),
    (region, ("track_force", "grow_box", "gated_track_force")),
    (following, ("lead_moment", "leash_reference")),
    (contact_safety, ("approach_scale", "limit_approach")),
    (planar, ("base_to_world",)),
):
    for _name in _names:
        register_jitable(getattr(_module, _name))

# -- state row of one task (S_*) ------------------------------------------------------------------
S_X, S_V, S_PSI_PREV, S_REF_SET, S_REF_ROT, S_REF_POS = 0, 6, 12, 13, 14, 23
S_POINT, S_HAD, S_LAST_SET, S_LAST = 26, 29, 30, 31
S_YIELDING, S_PEAK, S_TRANSIENT, S_TRAVEL, S_ELAPSED, S_EXHAUSTED = 34, 35, 36, 37, 38, 39
S_BOX_SET, S_BOX, S_AGE, S_ENGAGED = 40, 41, 47, 48
N_STATE = 54
# -- parameter row of one task (P_*) --------------------------------------------------------------
P_K_ETA, P_B, P_K_P, P_PSI_THR, P_DT, P_MARGIN, P_WINDOW, P_HYSTERESIS = range(8)
P_LOCK, P_DESIRED, P_USER_REF_SET, P_USER_REF, P_USER_BOX_SET, P_USER_BOX = 8, 9, 12, 13, 25, 26
P_LEAD, P_CARRY, P_LIMIT, P_TRANSIENT, P_FADE, P_RESET = 32, 33, 34, 35, 36, 37
P_YIELD_SPEED, P_REGAIN_DISTANCE, P_REGAIN_TIME = 38, 39, 40
N_PARAM = 41
# -- contact row (C_*): in_contact, centre, force, torque, region min, region max ---------------
C_IN, C_CENTER, C_FORCE, C_TORQUE, C_MIN, C_MAX = 0, 1, 4, 7, 10, 13
N_CONTACT = 16
# -- output row of one task (O_*): TaskOutput.values (36), then phase, ψ, ψ_raw, safety -----------
O_PHASE, O_PSI, O_PSI_RAW, O_SAFETY = 36, 37, 38, 39
N_OUT = 40
# Phase and Safety values (contact_task.Phase, contact_safety.Safety).
_INACTIVE, _ACTIVATING, _ACTIVE, _DEACTIVATING = 0.0, 1.0, 2.0, 3.0
_OK, _FADING, _YIELDING, _LOST = 0.0, 1.0, 2.0, 3.0
_HINGE, _SLIDE = int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE)


@njit(cache=True, inline="always")
def _v3(a: Array, i: int) -> tuple[float, float, float]:  # pragma: no cover - compiled
    return (a[i], a[i + 1], a[i + 2])


@njit(cache=True, inline="always")
def _m9(a: Array, i: int) -> tuple[float, ...]:  # pragma: no cover - compiled
    return (a[i], a[i + 1], a[i + 2], a[i + 3], a[i + 4], a[i + 5], a[i + 6], a[i + 7], a[i + 8])


@njit(cache=True)
def _reset_life(s: Array) -> None:  # pragma: no cover - compiled
    """Admittance zero and Algorithm 1 inactive (``Admittance.reset``, ``LifeCycle.reset``)."""
    s[S_X : S_X + 12] = 0.0
    s[S_PSI_PREV] = 0.0
    s[S_REF_SET] = 0.0


@njit(cache=True)
def _reset_region(s: Array) -> None:  # pragma: no cover - compiled
    """``DesiredRegion.reset``."""
    s[S_BOX_SET] = 0.0
    s[S_AGE] = 0.0
    s[S_ENGAGED : S_ENGAGED + 6] = 0.0


@njit(cache=True)
def _guard(s: Array, p: Array, force: float) -> float:  # pragma: no cover - compiled
    """``ForceGuard.update``: the approach scale s ∈ [0, 1] of this cycle's force ‖f‖ [N]."""
    if force > s[S_PEAK]:
        s[S_PEAK] = force
        if force > p[P_TRANSIENT]:
            s[S_TRANSIENT] = 1.0
    limit = p[P_RESET] * p[P_LIMIT] if s[S_YIELDING] != 0.0 else p[P_LIMIT]  # hysteresis
    yielding = force >= limit
    s[S_YIELDING] = 1.0 if yielding else 0.0
    if yielding:
        return 0.0
    return approach_scale(force, p[P_LIMIT], p[P_FADE])


@njit(cache=True)
def _regain(s: Array, p: Array, in_contact: bool, travel: float) -> bool:  # pragma: no cover
    """``RegainBudget.update``: whether the desired force may act this cycle."""
    if in_contact:
        s[S_TRAVEL] = 0.0
        s[S_ELAPSED] = 0.0
        s[S_EXHAUSTED] = 0.0
        return True
    s[S_TRAVEL] += travel
    s[S_ELAPSED] += p[P_DT]
    if s[S_TRAVEL] > p[P_REGAIN_DISTANCE] or s[S_ELAPSED] > p[P_REGAIN_TIME] + 1e-9:
        s[S_EXHAUSTED] = 1.0
    return s[S_EXHAUSTED] == 0.0


@njit(cache=True)
def _safety(s: Array, p: Array, c: Array,
            pos: tuple[float, float, float]) -> tuple:  # pragma: no cover - compiled
    """``ContactTask._safety``: (approach scale, desired-force scale, has n̂, n̂ link frame)."""
    in_contact = c[C_IN] != 0.0
    normal = (0.0, 0.0, 0.0)
    has_normal = False
    magnitude = 0.0
    if in_contact:
        fx, fy, fz = _v3(c, C_FORCE)
        magnitude = math.sqrt(fx * fx + fy * fy + fz * fz)
        if magnitude > 0.0:
            normal = (fx / magnitude, fy / magnitude, fz / magnitude)
            has_normal = True
    was_yielding = s[S_YIELDING] != 0.0
    scale = _guard(s, p, magnitude)
    if was_yielding and s[S_YIELDING] == 0.0:
        _reset_life(s)
    gate = True
    if p[P_DESIRED] != 0.0 or p[P_DESIRED + 1] != 0.0 or p[P_DESIRED + 2] != 0.0:
        travel = 0.0
        if s[S_LAST_SET] != 0.0:
            dx, dy, dz = pos[0] - s[S_LAST], pos[1] - s[S_LAST + 1], pos[2] - s[S_LAST + 2]
            travel = math.sqrt(dx * dx + dy * dy + dz * dz)
        s[S_LAST_SET] = 1.0
        s[S_LAST], s[S_LAST + 1], s[S_LAST + 2] = pos
        gate = _regain(s, p, in_contact, travel)
    return scale, scale if gate else 0.0, has_normal, normal


@njit(cache=True)
def _track_contact(s: Array, p: Array, c: Array) -> tuple:  # pragma: no cover - compiled
    """``ContactTask._track_contact``: (has ᶦṗ_η, ᶦṗ_η [m/s]); updates ᶦp_η."""
    rate = (0.0, 0.0, 0.0)
    has_rate = False
    if c[C_IN] != 0.0:
        center = _v3(c, C_CENTER)
        if s[S_HAD] != 0.0:
            rate = contact_rate(center, _v3(s, S_POINT), p[P_DT])
            has_rate = True
        s[S_POINT], s[S_POINT + 1], s[S_POINT + 2] = center
        s[S_HAD] = 1.0
    else:
        if s[S_HAD] != 0.0:
            _reset_region(s)
        s[S_HAD] = 0.0
    return has_rate, rate


@njit(cache=True)
def _wrench(s: Array, p: Array, c: Array, rot: tuple, yaw: float,
            desired_scale: float) -> tuple:  # pragma: no cover - compiled
    """``ContactTask._wrench``: ⁰w_η (12) + the scaled desired force, and ᶦμ (11) [m]."""
    mu = (0.0, 0.0, 0.0)
    w = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    if c[C_IN] != 0.0:
        lo, hi, force = _v3(c, C_MIN), _v3(c, C_MAX), _v3(c, C_FORCE)
        if s[S_BOX_SET] != 0.0:
            dlo, dhi = _v3(s, S_BOX), _v3(s, S_BOX + 3)
            if p[P_HYSTERESIS] == 0.0:
                mu = track_force(lo, hi, dlo, dhi)
            else:
                mu = gated_track_force(lo, hi, dlo, dhi, p[P_HYSTERESIS],
                                       s[S_ENGAGED : S_ENGAGED + 6])
        torque = _v3(c, C_TORQUE)
        if p[P_LEAD] != 0.0:
            tx, ty, tz = lead_moment(_v3(s, S_POINT), lo, hi, force)
            torque = (torque[0] + tx, torque[1] + ty, torque[2] + tz)
        wl = contact_wrench(force, torque, mu, p[P_K_ETA], rot)
        w = (wl[0], wl[1], wl[2], wl[3], wl[4], wl[5])
    fx, fy, fz = _v3(p, P_DESIRED)
    if desired_scale > 0.0 and (fx != 0.0 or fy != 0.0 or fz != 0.0):
        fx, fy, fz = desired_scale * fx, desired_scale * fy, desired_scale * fz
        dx, dy = planar.base_to_world(yaw, fx, fy)
        w = (w[0] + dx, w[1] + dy, w[2] + fz, w[3], w[4], w[5])
    return w, mu


@njit(cache=True)
def _admittance(s: Array, phi_gamma: Array, w: tuple) -> None:  # pragma: no cover - compiled
    """(13) discretised: ``[x̃; ẋ̃] ← Φ [x̃; ẋ̃] + Γ w`` (``Admittance.step_f``)."""
    old = s[S_X : S_X + 12].copy()
    for r in range(12):
        acc = 0.0
        for j in range(12):
            acc += phi_gamma[r, j] * old[j]
        for j in range(6):
            acc += phi_gamma[r, 12 + j] * w[j]
        s[S_X + r] = acc


@njit(cache=True)
def _advance(s: Array, p: Array, psi_raw: float, rot: tuple,
             pos: tuple) -> tuple:  # pragma: no cover - compiled
    """``LifeCycle.advance`` (Algorithm 1 lines 3–10): (activating, deactivated, active)."""
    thr, prev = p[P_PSI_THR], s[S_PSI_PREV]
    activating = prev <= thr < psi_raw
    deactivated = prev >= thr > psi_raw
    if activating:
        if p[P_USER_REF_SET] != 0.0:
            s[S_REF_ROT : S_REF_ROT + 12] = p[P_USER_REF : P_USER_REF + 12]
        else:
            for k in range(9):
                s[S_REF_ROT + k] = rot[k]
            s[S_REF_POS], s[S_REF_POS + 1], s[S_REF_POS + 2] = pos
        s[S_REF_SET] = 1.0
    if deactivated:
        s[S_REF_SET] = 0.0
    s[S_PSI_PREV] = psi_raw
    return activating, deactivated, psi_raw >= thr and s[S_REF_SET] != 0.0


@njit(cache=True)
def _carry(s: Array, rot: tuple) -> None:  # pragma: no cover - compiled
    """``ContactTask._carry_reference`` (F2)."""
    if s[S_REF_SET] == 0.0:
        return
    carried = leash_reference(_m9(s, S_REF_ROT), _v3(s, S_X + 3), _v3(s, S_V + 3), rot)
    if carried is not None:
        new_rot, rate = carried
        for k in range(9):
            s[S_REF_ROT + k] = new_rot[k]
        s[S_X + 3 : S_X + 6] = 0.0
        s[S_V + 3], s[S_V + 4], s[S_V + 5] = rate


@njit(cache=True)
def _region_update(s: Array, p: Array, c: Array) -> None:  # pragma: no cover - compiled
    """``DesiredRegion.update`` (Algorithm 1 line 14, onset window)."""
    lo, hi = _v3(c, C_MIN), _v3(c, C_MAX)
    user = p[P_USER_BOX_SET] != 0.0
    if s[S_BOX_SET] == 0.0:
        s[S_AGE] = 0.0
        if user:
            s[S_BOX : S_BOX + 6] = p[P_USER_BOX : P_USER_BOX + 6]
        else:
            (a, b, cc), (d, e, f) = grow_box((hi, lo), lo, hi, p[P_MARGIN])
            s[S_BOX : S_BOX + 6] = np.array((a, b, cc, d, e, f))
        s[S_BOX_SET] = 1.0
    elif not user and s[S_AGE] < p[P_WINDOW] - 1e-12:
        (a, b, cc), (d, e, f) = grow_box((_v3(s, S_BOX), _v3(s, S_BOX + 3)), lo, hi,
                                         p[P_MARGIN])
        s[S_BOX : S_BOX + 6] = np.array((a, b, cc, d, e, f))
    s[S_AGE] += p[P_DT]


@njit(cache=True)
def _velocities(s: Array, p: Array, rot: tuple, pos: tuple, has_rate: bool,
                rate: tuple) -> tuple:  # pragma: no cover - compiled
    """``ContactTask._velocities``: (14), (16)–(20), (8): target (6) and control (6)."""
    x = (s[0], s[1], s[2], s[3], s[4], s[5])
    v = (s[6], s[7], s[8], s[9], s[10], s[11])
    rot_d, omega_d = desired_orientation(_m9(s, S_REF_ROT), (x[3], x[4], x[5]),
                                         (v[3], v[4], v[5]))
    (lx, ly, lz), (ax, ay, az) = task_velocity(rot, pos, _v3(s, S_POINT), _v3(s, S_REF_POS),
                                               rot_d, omega_d, x, v, p[P_K_P])
    if not has_rate:
        return (lx, ly, lz, ax, ay, az, lx, ly, lz, ax, ay, az)
    (dx, dy, dz), (sx, sy, sz) = sliding_terms(rot_d, rot, rate)
    return (lx + (dx - sx), ly + (dy - sy), lz + (dz - sz), ax, ay, az,
            lx + dx, ly + dy, lz + dz, ax, ay, az)


@njit(cache=True)
def _guarded(s: Array, p: Array, vel: tuple, rot: tuple, has_normal: bool, normal: tuple,
             scale: float) -> tuple:  # pragma: no cover - compiled
    """``ContactTask._guarded``: the graded response on target and control velocities."""
    if not has_normal:
        return vel
    n = rotate(rot, normal)
    if s[S_YIELDING] != 0.0:
        y = p[P_YIELD_SPEED]
        return (y * n[0], y * n[1], y * n[2], 0.0, 0.0, 0.0,
                y * n[0], y * n[1], y * n[2], 0.0, 0.0, 0.0)
    t = limit_approach((vel[0], vel[1], vel[2]), n, scale)
    u = limit_approach((vel[6], vel[7], vel[8]), n, scale)
    return (t[0], t[1], t[2], vel[3], vel[4], vel[5], u[0], u[1], u[2], vel[9], vel[10], vel[11])


@njit(cache=True)
def _task_step(s: Array, p: Array, phi_gamma: Array, c: Array, rot: tuple, pos: tuple,
               yaw: float, out: Array) -> None:  # pragma: no cover - compiled
    """:meth:`ContactTask.step` of one link on its state row ``s``; ``out`` (:data:`N_OUT`)."""
    in_contact = c[C_IN] != 0.0
    scale, desired_scale, has_normal, normal = _safety(s, p, c, pos)
    has_rate, rate = _track_contact(s, p, c)
    w, mu = _wrench(s, p, c, rot, yaw, desired_scale)
    _admittance(s, phi_gamma, w)
    lock = p[P_LOCK]
    psi_raw = lock if not math.isnan(lock) else priority(
        (s[6], s[7], s[8], s[9], s[10], s[11]), p[P_B])
    activating, deactivated, active = _advance(s, p, psi_raw, rot, pos)
    if deactivated:
        s[S_X : S_X + 12] = 0.0
        _reset_region(s)
    if active and p[P_CARRY] != 0.0:
        _carry(s, rot)
    if active and in_contact:
        _region_update(s, p, c)
    vel = (0.0,) * 12
    phase = _INACTIVE
    if active:
        phase = _ACTIVATING if activating else (
            _ACTIVE if in_contact or not math.isnan(lock) else _DEACTIVATING)
        vel = _velocities(s, p, rot, pos, has_rate, rate)
    else:
        s[S_X : S_X + 6] = 0.0
    if scale < 1.0:
        vel = _guarded(s, p, vel, rot, has_normal, normal, scale)
    elif s[S_EXHAUSTED] != 0.0:
        _reset_life(s)
        vel = (0.0,) * 12
    _outputs(s, p, vel, w, rotate(rot, mu), phase, psi_raw, scale, out)


@njit(cache=True)
def _outputs(s: Array, p: Array, vel: tuple, w: tuple, mu_world: tuple, phase: float,
             psi_raw: float, scale: float, out: Array) -> None:  # pragma: no cover - compiled
    """The :class:`TaskOutput` values (layout of ``contact_task``) and phase, ψ, ψ_raw, safety."""
    for k in range(12):
        out[k] = vel[k]
    for k in range(6):
        out[12 + k] = w[k]
    out[18:30] = s[S_X : S_X + 12]
    out[30:33] = s[S_POINT : S_POINT + 3]
    k_eta = p[P_K_ETA]
    out[33], out[34], out[35] = k_eta * mu_world[0], k_eta * mu_world[1], k_eta * mu_world[2]
    thr = p[P_PSI_THR]
    yielding = s[S_YIELDING] != 0.0
    out[O_PHASE] = phase
    out[O_PSI] = 1.0 if yielding else (psi_raw if psi_raw > thr else thr)
    out[O_PSI_RAW] = psi_raw
    safety = _OK
    if yielding:
        safety = _YIELDING
    elif scale < 1.0:
        safety = _FADING
    elif s[S_EXHAUSTED] != 0.0 and (p[P_DESIRED] != 0.0 or p[P_DESIRED + 1] != 0.0
                                    or p[P_DESIRED + 2] != 0.0):
        safety = _LOST
    out[O_SAFETY] = safety


@njit(cache=True)
def _jacobian(chain: NDArray[np.int64], xaxis: Array, xanchor: Array, rot: tuple, pos: tuple,
              point: tuple, c: float, s: float, out: Array) -> None:  # pragma: no cover
    """J_i of (8) in the command u, written into ``out`` (6×n, zeroed here).

    The point ⁰p_η = ⁰R_i ᶦp_η + ⁰p_γi (6) moves with every joint between it and the world
    (``chain`` rows: joint id, its DOF = column, MuJoCo type): a hinge of world axis a through
    the anchor o adds ``[a × (⁰p_η − o); a]`` to its column, a slide ``[a; 0]`` — the columns
    of MuJoCo's ``mj_jac``, from the joint frames ``mj_kinematics`` computed. Then the base
    columns rotated by the yaw (c, s) = (cos, sin) (``controller`` module docstring).
    """
    rx, ry, rz = rotate(rot, point)
    px, py, pz = rx + pos[0], ry + pos[1], rz + pos[2]
    out[:, :] = 0.0
    for row in range(chain.shape[0]):
        joint, col, kind = chain[row, 0], chain[row, 1], chain[row, 2]
        if joint < 0:
            break
        ax, ay, az = xaxis[joint, 0], xaxis[joint, 1], xaxis[joint, 2]
        if kind == _HINGE:
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


def joint_chain(model: mujoco.MjModel, body: int) -> list[tuple[int, int, int]]:
    """(joint id, DOF, type) of every joint between ``body`` and the world, body first."""
    chain = []
    while body > 0:
        first = int(model.body_jntadr[body])
        for joint in range(first, first + int(model.body_jntnum[body])):
            chain.append((joint, int(model.jnt_dofadr[joint]), int(model.jnt_type[joint])))
        body = int(model.body_parentid[body])
    return chain


@njit(cache=True)
def _build_qp(jacobian: Array, target: Array, weights: Array, q: Array, limits: Array,
              horizon: float, epsilon: float, hessian: Array, gradient: Array,
              lower: Array, upper: Array) -> bool:  # pragma: no cover - compiled
    """(23) as :meth:`QPBuilder.build`: ``H = Jᵀ (2Ψ J) + 2ε I``, ``g = −(2Ψ J)ᵀ b`` and the
    bounds (22) ``clip((q_l,u − q)/h, q̇_l, q̇_u)`` from ``limits`` (4×n: q_l, q_u, q̇_l, q̇_u);
    False where H's diagonal or g is not finite."""
    rows, n = jacobian.shape
    hessian[:, :] = 0.0
    gradient[:] = 0.0
    for r in range(rows):  # row by row: contiguous, and a link's zero columns are skipped
        w, b = weights[r], target[r]
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
        bound = max((limits[0, i] - q[i]) / horizon, limits[2, i])
        lower[i] = min(bound, limits[3, i])
        bound = max((limits[1, i] - q[i]) / horizon, limits[2, i])
        upper[i] = min(bound, limits[3, i])
    return math.isfinite(check)


@njit(cache=True)
def step_kernel(state: Array, params: Array, phi_gamma: Array, contacts: Array, xmat: Array,
                xpos: Array, bodies: NDArray[np.int64], chains: NDArray[np.int64],
                xaxis: Array, xanchor: Array, q: Array,
                limits: Array, horizon: float, epsilon: float, outputs: Array, target: Array,
                jacobian: Array, hessian: Array, gradient: Array,
                lower: Array, upper: Array) -> bool:  # pragma: no cover - compiled
    """One control step of every link after the kinematics: the tasks, their Jacobians and (23).

    Args:
        state, params: (k, :data:`N_STATE`), (k, :data:`N_PARAM`) task rows (state updated).
        phi_gamma: (k, 12, 18) ``[Φ Γ]`` of each admittance (13).
        contacts: this cycle's contact rows (link frame), :data:`N_CONTACT` floats per link.
        xmat, xpos: MuJoCo's world frames of the bodies (nbody×9, nbody×3).
        bodies: body id of each link.
        chains: (k, L, 3) each link's :func:`joint_chain`, padded with −1 rows.
        xaxis, xanchor: MuJoCo's world joint axes and anchors (njnt×3).
        q: configuration (n) [m, rad]; limits: (4, n) q_l, q_u, q̇_l, q̇_u; horizon h [s];
            epsilon ε of (23).
        outputs, target, jacobian, hessian, gradient, lower, upper: written: the tasks' rows
            (k, N_OUT), b (6k), J in u (6k×n), H (n×n), g (n), the bounds (n each) of (23).
            The caller allocates them: numba returns arrays at a cost of about a µs each.

    Returns:
        Whether H's diagonal and g are finite.
    """
    k = state.shape[0]
    yaw = q[2]
    c, s = math.cos(yaw), math.sin(yaw)
    weights = np.empty(6 * k)
    for i in range(k):
        body = bodies[i]
        rot = _m9(xmat[body], 0)
        pos = _v3(xpos[body], 0)
        out = outputs[i]
        _task_step(state[i], params[i], phi_gamma[i],
                   contacts[N_CONTACT * i : N_CONTACT * (i + 1)], rot, pos, yaw, out)
        psi2 = 2.0 * out[O_PSI]
        for r in range(6):
            target[6 * i + r] = out[r]
            weights[6 * i + r] = psi2
        _jacobian(chains[i], xaxis, xanchor, rot, pos, _v3(state[i], S_POINT), c, s,
                  jacobian[6 * i : 6 * i + 6])
    return _build_qp(jacobian, target, weights, q, limits, horizon, epsilon, hessian,
                     gradient, lower, upper)


# -- the Python side: rows from the task objects and back, the MuJoCo calls, one step -------------
def task_params(task: ContactTask) -> Array:
    """The parameter row (``P_*``) of one task: its gains, settings and safety limits."""
    p = np.zeros(N_PARAM)
    p[P_K_ETA : P_HYSTERESIS + 1] = (task.k_eta, task.b, task.k_p, task.psi_thr, task.dt,
                                     task.region.margin, task.region.window,
                                     task.region.hysteresis)
    lock = task.config.priority_lock
    p[P_LOCK] = math.nan if lock is None else lock
    p[P_DESIRED : P_DESIRED + 3] = task.desired_force
    user = task.life_cycle.user_reference
    if user is not None:
        p[P_USER_REF_SET] = 1.0
        p[P_USER_REF : P_USER_REF + 12] = (*user[0], *user[1])
    if task.region.user is not None:
        p[P_USER_BOX_SET] = 1.0
        p[P_USER_BOX : P_USER_BOX + 6] = (*task.region.user[0], *task.region.user[1])
    p[P_LEAD], p[P_CARRY] = float(task.lead), float(task.carries_reference)
    guard, safety = task.guard, task.safety
    p[P_LIMIT : P_REGAIN_TIME + 1] = (guard.limit, guard.transient_limit, safety.fade_start,
                                      safety.reset_ratio, safety.yield_speed,
                                      safety.regain_distance, safety.regain_time)
    return p


def store_state(task: ContactTask, s: Array) -> None:
    """A task's state (admittance, Algorithm 1, ᶦp_η, safety, Ω_d) into its row ``s``."""
    x, v = task.admittance.state_f
    s[:] = 0.0
    s[S_X : S_X + 6], s[S_V : S_V + 6] = x, v
    life = task.life_cycle
    s[S_PSI_PREV] = life.psi_prev
    if life.reference is not None:
        s[S_REF_SET] = 1.0
        s[S_REF_ROT : S_REF_POS + 3] = (*life.reference[0], *life.reference[1])
    s[S_POINT : S_POINT + 3] = task.jacobian_point
    s[S_HAD] = float(task._had_contact)
    if task._last_pos is not None:
        s[S_LAST_SET] = 1.0
        s[S_LAST : S_LAST + 3] = task._last_pos
    guard, regain = task.guard, task.regain
    s[S_YIELDING : S_EXHAUSTED + 1] = (guard.yielding, guard.peak, guard.transient_exceeded,
                                       regain.travel, regain.elapsed, regain.exhausted)
    box = task.region.box
    if box is not None:
        s[S_BOX_SET] = 1.0
        s[S_BOX : S_BOX + 6] = (*box[0], *box[1])
    s[S_AGE] = task.region._age
    s[S_ENGAGED : S_ENGAGED + 6] = task.region._engaged


def load_state(task: ContactTask, s: Array) -> None:
    """The inverse of :func:`store_state`: the task objects take the row's state."""
    row = s.tolist()
    task.admittance.set_state(row[S_X : S_X + 6], row[S_V : S_V + 6])
    life = task.life_cycle
    life.psi_prev = row[S_PSI_PREV]
    life.reference = None if not row[S_REF_SET] else (
        tuple(row[S_REF_ROT : S_REF_ROT + 9]), _vec3(row, S_REF_POS))
    task._point = _vec3(row, S_POINT)
    task.jacobian_point = np.array(task._point)
    task._had_contact = bool(row[S_HAD])
    task._last_pos = _vec3(row, S_LAST) if row[S_LAST_SET] else None
    guard, regain = task.guard, task.regain
    guard.yielding, guard.peak = bool(row[S_YIELDING]), row[S_PEAK]
    guard.transient_exceeded = bool(row[S_TRANSIENT])
    regain.travel, regain.elapsed = row[S_TRAVEL], row[S_ELAPSED]
    regain.exhausted = bool(row[S_EXHAUSTED])
    task.region.box = (_vec3(row, S_BOX), _vec3(row, S_BOX + 3)) if row[S_BOX_SET] else None
    task.region._age = row[S_AGE]
    task.region._engaged = [bool(e) for e in row[S_ENGAGED : S_ENGAGED + 6]]


def _vec3(row: list[float], i: int) -> tuple[float, float, float]:
    return (row[i], row[i + 1], row[i + 2])


_PHASES = tuple(Phase)
_SAFETIES = tuple(Safety)
_NO_CONTACT = [0.0] * N_CONTACT
_make_output = TaskOutput._make
_new_tuple = tuple.__new__  # QPProblem(...) without the NamedTuple's Python-level __new__


def supports(kinematics: object) -> bool:
    """Whether the compiled step can drive ``kinematics``: a :class:`RobotKinematics` whose
    MuJoCo positions and DOFs are q itself (the default model). Otherwise the controller runs
    the Python step."""
    if not isinstance(kinematics, RobotKinematics) or not kinematics.dofs_are_q:
        return False
    kinds = kinematics.model.jnt_type
    return bool(np.all((kinds == _HINGE) | (kinds == _SLIDE)))


class CompiledStep:
    """The rows of the controller's tasks for :func:`step_kernel` and the calls around it.

    Args:
        tasks: the controller's tasks (parameters are read once; state by :meth:`store`).
        kinematics: see :func:`supports`.
        limits: (4, n) q_l, q_u, q̇_l, q̇_u of (22) [m, rad, m/s, rad/s].
        horizon: h of (22) [s]; epsilon: ε of (23).
    """

    def __init__(self, tasks: Sequence[ContactTask], kinematics: RobotKinematics,
                 limits: Array, horizon: float, epsilon: float) -> None:
        if not supports(kinematics):
            raise ValueError("the compiled step needs a RobotKinematics whose DOFs are q")
        k, n = len(tasks), kinematics.nq
        self.links = tuple(task.config.link for task in tasks)
        self.params = np.array([task_params(task) for task in tasks]).reshape(k, N_PARAM)
        self.phi_gamma = np.array([np.hstack(task.admittance.matrices) for task in tasks]
                                  ).reshape(k, 12, 18)
        self.state = np.zeros((k, N_STATE))
        self.bodies = np.array([kinematics.body_id(link) for link in self.links], dtype=np.int64)
        model = kinematics.model
        chains = [joint_chain(model, int(body)) for body in self.bodies]
        self.chains = np.full((k, max(map(len, chains), default=0), 3), -1, dtype=np.int64)
        for i, chain in enumerate(chains):
            self.chains[i, : len(chain)] = chain
        self._n, self._rows = n, 6 * k
        self._outputs = np.zeros((k, N_OUT))
        self.limits = np.ascontiguousarray(limits, dtype=np.float64)
        self.horizon, self.epsilon = float(horizon), float(epsilon)
        self._model, self._data = kinematics.model, kinematics.data
        self._qpos = kinematics.data.qpos
        self.store(tasks)

    def store(self, tasks: Sequence[ContactTask]) -> None:
        """Take the tasks' state (:func:`store_state`)."""
        for task, row in zip(tasks, self.state, strict=True):
            store_state(task, row)

    def load(self, tasks: Sequence[ContactTask]) -> None:
        """Give the tasks the compiled state (:func:`load_state`)."""
        for task, row in zip(tasks, self.state, strict=True):
            load_state(task, row)

    def warm_up(self) -> None:
        """Compile (or load from the cache) and run the kernel once on scratch copies."""
        k, n, data = len(self.links), self._n, self._data
        step_kernel(self.state.copy(), self.params, self.phi_gamma, np.zeros(k * N_CONTACT),
                    data.xmat, data.xpos, self.bodies, self.chains, data.xaxis,
                    data.xanchor, np.zeros(n), self.limits, self.horizon, self.epsilon,
                    np.empty((k, N_OUT)), np.empty(6 * k), np.empty((6 * k, n)),
                    np.empty((n, n)), np.empty(n), np.empty(n), np.empty(n))

    def step(self, q: Array, contacts: Mapping[str, ContactState]) -> tuple:
        """Kinematics at q (finite, checked by the caller) and :func:`step_kernel`.

        Returns:
            ``(task outputs, target, jacobian, QP (23), finite)``.
        """
        model, data = self._model, self._data
        self._qpos[:] = q
        mujoco.mj_kinematics(model, data)
        rows: list[float] = []
        touched = []
        get = contacts.get
        for link in self.links:
            c = get(link)
            if c is None or not c.in_contact:
                rows += _NO_CONTACT
                touched.append(False)
                continue
            rows.append(1.0)
            rows += c.center.tolist()
            rows += c.force.tolist()
            rows += c.torque.tolist()
            rows += c.region_min.tolist()
            rows += c.region_max.tolist()
            touched.append(True)
        # Fresh arrays where the result keeps them (StepResult, QPProblem); ``outputs`` is scratch.
        empty, n, outputs = np.empty, self._n, self._outputs
        target, jacobian = empty(self._rows), empty((self._rows, n))
        hessian, gradient, lower, upper = empty((n, n)), empty(n), empty(n), empty(n)
        finite = step_kernel(
            self.state, self.params, self.phi_gamma, np.array(rows), data.xmat, data.xpos,
            self.bodies, self.chains, data.xaxis, data.xanchor, q, self.limits, self.horizon,
            self.epsilon, outputs, target, jacobian, hessian, gradient, lower, upper)
        tasks = tuple(
            _make_output((link, _PHASES[int(row[O_PHASE])], row[O_PSI], row[O_PSI_RAW], hit,
                          tuple(row[:O_PHASE]), _SAFETIES[int(row[O_SAFETY])]))
            for link, row, hit in zip(self.links, outputs.tolist(), touched, strict=True))
        problem = _new_tuple(QPProblem, (hessian, gradient, lower, upper))
        return tasks, target, jacobian, problem, finite


def _drop_stale_cache() -> None:
    """Delete this module's compiled cache if the compiled-in modules' source changed since it
    was written (fingerprint in ``fused.sources``, next to the cache)."""
    try:
        # numba's cache folder for this file
        folder = Path(step_kernel._cache._cache_path)  # type: ignore[attr-defined]
        modules = (so3, linalg3, contact_task, region, following, contact_safety, planar)
        digest = hashlib.sha256(b"".join(inspect.getsource(m).encode() for m in modules))
        stamp = folder / "fused.sources"
        if stamp.exists() and stamp.read_text() == digest.hexdigest():
            return
        for path in folder.glob("fused.*.nb[ic]"):
            path.unlink(missing_ok=True)
        stamp.write_text(digest.hexdigest())
    except (OSError, AttributeError):  # read-only install, or a numba without this layout:
        pass  # numba then recompiles in memory or keeps its own rules


_drop_stale_cache()
