"""One control step of one link's interaction task, on its rows (:mod:`task_rows`).

The step, in order (:func:`step_task`):

1. contact safety (:mod:`contact_safety`): the force guard's graded response to ‖f‖ and the
   regain budget of a manual desired force;
2. the contact centre ᶦp_η and its rate on the skin (fn. 2);
3. the wrench (12) with the track force (10)–(11) against Ω_d (:mod:`region`), the lead moment
   (F1, :mod:`following`) and the gated desired force;
4. the admittance (13) on that wrench through its dead zone (D1, :mod:`admittance`);
5. Algorithm 1: ψ (15) or the lock, activation (lock x_r), deactivation (line 10: reset);
6. while active: the leash (F2), Ω_d locked or grown (line 14 and the onset window), and the
   commanded velocity of the contact centre (14), (16)–(20);
7. the graded response on that velocity (fade, yield at a speed graded by the excess over the
   limit) or, once the regain budget is spent, stop; the output row carries the yield's excess
   scale σ, by which :func:`~wholebody_controller.whole_step.qp_of_step` opens the bounds.

Every function here is plain Python on numpy rows and plain floats, and :func:`jitable`: the
compiled kernel (:mod:`kernels`) runs exactly this code, ``kernel: python`` runs it
interpreted. The formulas themselves are in :mod:`contact_task`, :mod:`region`,
:mod:`following`, :mod:`contact_safety` and :mod:`admittance`.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from phri_common.jit import jitable
from phri_common.planar import base_to_world
from wholebody_controller.admittance import admittance_step, dead_zone, turn_gate
from wholebody_controller.contact_safety import (
    approach_scale,
    limit_approach,
    yield_scale,
    yield_speed_of,
)
from wholebody_controller.contact_task import (
    contact_rate,
    contact_wrench,
    desired_orientation,
    priority,
    sliding_terms,
    task_velocity,
)
from wholebody_controller.following import lead_moment, leash_position, leash_reference
from wholebody_controller.linalg3 import rotate
from wholebody_controller.region import gated_track_force, grow_box, track_force
from wholebody_controller.task_rows import (
    C_CENTER,
    C_FORCE,
    C_IN,
    C_MAX,
    C_MIN,
    C_TORQUE,
    O_PHASE,
    O_PSI,
    O_PSI_RAW,
    O_SAFETY,
    O_YIELD,
    P_B,
    P_CARRY,
    P_CARRY_POS,
    P_DEADBAND_F,
    P_DEADBAND_T,
    P_DESIRED,
    P_DT,
    P_FADE,
    P_FULL_EXCESS,
    P_HYSTERESIS,
    P_K_ETA,
    P_K_P,
    P_LEAD,
    P_LIMIT,
    P_LOCK,
    P_MARGIN,
    P_PSI_THR,
    P_REGAIN_DISTANCE,
    P_REGAIN_TIME,
    P_RESET,
    P_TRANSIENT,
    P_TURN_FORCE,
    P_USER_BOX,
    P_USER_BOX_SET,
    P_USER_REF,
    P_USER_REF_SET,
    P_WINDOW,
    P_YIELD_MAX,
    P_YIELD_SPEED,
    S_AGE,
    S_BOX,
    S_BOX_SET,
    S_ELAPSED,
    S_ENGAGED,
    S_EXHAUSTED,
    S_HAD,
    S_LAST,
    S_LAST_SET,
    S_OPENED,
    S_PEAK,
    S_POINT,
    S_PSI_PREV,
    S_REF_POS,
    S_REF_ROT,
    S_REF_SET,
    S_TRANSIENT,
    S_TRAVEL,
    S_V,
    S_X,
    S_YIELDING,
)

Array = NDArray[np.float64]

# Phase and Safety as floats in the output row (contact_task.Phase, contact_safety.Safety).
_INACTIVE, _ACTIVATING, _ACTIVE, _DEACTIVATING = 0.0, 1.0, 2.0, 3.0
_OK, _FADING, _YIELDING, _LOST = 0.0, 1.0, 2.0, 3.0
_REGAIN_TIME_SLACK = 1e-9
"""[s]: a time summed from periods (200 × 0.01 s) must not spend the budget one period early."""
_WINDOW_SLACK = 1e-12
"""[s]: the same for the onset window of Ω_d."""


@jitable
def _v3(a: Array, i: int) -> tuple[float, float, float]:
    return (a[i], a[i + 1], a[i + 2])


@jitable
def _m9(a: Array, i: int) -> tuple[float, ...]:
    return (a[i], a[i + 1], a[i + 2], a[i + 3], a[i + 4], a[i + 5], a[i + 6], a[i + 7], a[i + 8])


@jitable
def forget(s: Array) -> None:
    """Admittance at rest and Algorithm 1 inactive: nothing locked (a stop or a yield's end)."""
    s[S_X : S_X + 12] = 0.0
    s[S_PSI_PREV] = 0.0
    s[S_REF_SET] = 0.0


@jitable
def reset_region(s: Array) -> None:
    """No Ω_d: the touch it belonged to is over, or the task deactivated."""
    s[S_BOX_SET] = 0.0
    s[S_AGE] = 0.0
    s[S_ENGAGED : S_ENGAGED + 6] = 0.0


@jitable
def guard_update(s: Array, p: Array, force: float) -> float:
    """The force guard (:mod:`contact_safety`): this cycle's contact force ‖f‖ [N] → the
    approach scale s ∈ [0, 1]; yielding from F until ‖f‖ < r·F (hysteresis); the peak and
    whether the transient limit was ever exceeded are recorded."""
    if force > s[S_PEAK]:
        s[S_PEAK] = force
        if force > p[P_TRANSIENT]:
            s[S_TRANSIENT] = 1.0
    threshold = p[P_RESET] * p[P_LIMIT] if s[S_YIELDING] != 0.0 else p[P_LIMIT]
    yielding = force >= threshold
    s[S_YIELDING] = 1.0 if yielding else 0.0
    if yielding:
        return 0.0
    return approach_scale(force, p[P_LIMIT], p[P_FADE])


@jitable
def regain_update(s: Array, p: Array, in_contact: bool, travel: float) -> bool:
    """The regain budget (:mod:`contact_safety`): whether a desired force may act this cycle,
    given the link frame's ``travel`` [m] since the previous one; a touch refills it."""
    if in_contact:
        s[S_TRAVEL] = 0.0
        s[S_ELAPSED] = 0.0
        s[S_EXHAUSTED] = 0.0
        return True
    s[S_TRAVEL] += travel
    s[S_ELAPSED] += p[P_DT]
    if (s[S_TRAVEL] > p[P_REGAIN_DISTANCE]
            or s[S_ELAPSED] > p[P_REGAIN_TIME] + _REGAIN_TIME_SLACK):
        s[S_EXHAUSTED] = 1.0
    return s[S_EXHAUSTED] == 0.0


@jitable
def contact_force(c: Array) -> float:
    """‖f‖ [N] of a contact row, 0 when untouched."""
    if c[C_IN] == 0.0:
        return 0.0
    fx, fy, fz = _v3(c, C_FORCE)
    return math.sqrt(fx * fx + fy * fy + fz * fz)


@jitable
def has_desired_force(p: Array) -> bool:
    """Whether the link carries a manual desired force."""
    return p[P_DESIRED] != 0.0 or p[P_DESIRED + 1] != 0.0 or p[P_DESIRED + 2] != 0.0


@jitable
def contact_safety(s: Array, p: Array, c: Array, pos: tuple[float, float, float]) -> tuple:
    """This cycle's contact safety: ``(approach scale, desired-force scale, has n̂, n̂, σ)``, n̂
    the unit contact force in the link frame, σ the yield's excess scale (0 unless yielding);
    updates the guard, the regain budget (the link frame at ``pos`` [m]) and the opened bounds
    (the largest σ of the yield, held until the force falls to the fade start). A yield that
    ends starts the task afresh."""
    in_contact = c[C_IN] != 0.0
    normal = (0.0, 0.0, 0.0)
    has_normal = False
    magnitude = contact_force(c)
    if magnitude > 0.0:
        fx, fy, fz = _v3(c, C_FORCE)
        normal = (fx / magnitude, fy / magnitude, fz / magnitude)
        has_normal = True
    was_yielding = s[S_YIELDING] != 0.0
    scale = guard_update(s, p, magnitude)
    if was_yielding and s[S_YIELDING] == 0.0:
        forget(s)
    gate = True
    if has_desired_force(p):
        travel = 0.0
        if s[S_LAST_SET] != 0.0:
            dx, dy, dz = pos[0] - s[S_LAST], pos[1] - s[S_LAST + 1], pos[2] - s[S_LAST + 2]
            travel = math.sqrt(dx * dx + dy * dy + dz * dz)
        s[S_LAST_SET] = 1.0
        s[S_LAST], s[S_LAST + 1], s[S_LAST + 2] = pos
        gate = regain_update(s, p, in_contact, travel)
    sigma = 0.0
    if s[S_YIELDING] != 0.0:
        sigma = yield_scale(magnitude, p[P_LIMIT], p[P_FULL_EXCESS])
        s[S_OPENED] = max(s[S_OPENED], sigma)
    elif magnitude <= p[P_FADE] * p[P_LIMIT]:
        s[S_OPENED] = 0.0  # the push is over: the bounds close, the band returns
    return scale, scale if gate else 0.0, has_normal, normal, sigma


@jitable
def track_contact(s: Array, p: Array, c: Array) -> tuple:
    """ᶦp_η from a touched contact and ``(has ᶦṗ_η, ᶦṗ_η [m/s])`` between two touched steps; a
    release drops Ω_d (it belonged to that touch; a new touch locks its own)."""
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
            reset_region(s)
        s[S_HAD] = 0.0
    return has_rate, rate


@jitable
def region_track_force(s: Array, p: Array, lo: tuple, hi: tuple) -> tuple[float, float, float]:
    """μ (10)–(11) [m] of Ω_i = [lo, hi] against Ω_d (zero before Ω_d is locked), each face
    behind its hysteresis trigger when ``region_hysteresis`` > 0 (:mod:`region`)."""
    if s[S_BOX_SET] == 0.0:
        return (0.0, 0.0, 0.0)
    dlo, dhi = _v3(s, S_BOX), _v3(s, S_BOX + 3)
    if p[P_HYSTERESIS] == 0.0:
        return track_force(lo, hi, dlo, dhi)
    return gated_track_force(lo, hi, dlo, dhi, p[P_HYSTERESIS], s[S_ENGAGED : S_ENGAGED + 6])


@jitable
def link_wrench(s: Array, p: Array, c: Array, rot: tuple, yaw: float,
                desired_scale: float) -> tuple:
    """⁰w_η (12) [N, N·m] with the lead moment (F1) and ``desired_scale`` times the manual
    desired force (base frame → world by ``yaw``), and ᶦμ [m]."""
    mu = (0.0, 0.0, 0.0)
    w = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    if c[C_IN] != 0.0:
        lo, hi, force = _v3(c, C_MIN), _v3(c, C_MAX), _v3(c, C_FORCE)
        mu = region_track_force(s, p, lo, hi)
        torque = _v3(c, C_TORQUE)
        if p[P_LEAD] != 0.0:
            tx, ty, tz = lead_moment(_v3(s, S_POINT), lo, hi, force)
            torque = (torque[0] + tx, torque[1] + ty, torque[2] + tz)
        wl = contact_wrench(force, torque, mu, p[P_K_ETA], rot)
        w = (wl[0], wl[1], wl[2], wl[3], wl[4], wl[5])
    fx, fy, fz = _v3(p, P_DESIRED)
    if desired_scale > 0.0 and (fx != 0.0 or fy != 0.0 or fz != 0.0):
        fx, fy, fz = desired_scale * fx, desired_scale * fy, desired_scale * fz
        dx, dy = base_to_world(yaw, fx, fy)
        w = (w[0] + dx, w[1] + dy, w[2] + fz, w[3], w[4], w[5])
    return w, mu


@jitable
def advance(s: Array, p: Array, psi_raw: float, rot: tuple, pos: tuple) -> tuple:
    """Algorithm 1, lines 3–10: ψ crossing ψ_thr upwards locks x_r (the user's reference, else
    the link's pose ``rot``, ``pos``), downwards releases it. ``(activating, deactivated,
    active)``; active = ψ ≥ ψ_thr with x_r locked (a NaN ψ is never active)."""
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


@jitable
def carry_reference(s: Array, p: Array, rot: tuple, pos: tuple) -> None:
    """(F2): re-base x_r's rotation when the desired orientation leads the link's ``rot`` by
    more than the leash, or fold the deflection into it; (F3): re-base x_r's position when the
    desired contact point leads the link's by more than its leash (:mod:`following`)."""
    if s[S_REF_SET] == 0.0:
        return
    if p[P_CARRY] != 0.0:
        carried = leash_reference(_m9(s, S_REF_ROT), _v3(s, S_X + 3), _v3(s, S_V + 3), rot)
        if carried is not None:
            new_rot, rate = carried
            for k in range(9):
                s[S_REF_ROT + k] = new_rot[k]
            s[S_X + 3 : S_X + 6] = 0.0
            s[S_V + 3], s[S_V + 4], s[S_V + 5] = rate
    if p[P_CARRY_POS] != 0.0:
        rot_d, _ = desired_orientation(_m9(s, S_REF_ROT), _v3(s, S_X + 3), _v3(s, S_V + 3))
        point = _v3(s, S_POINT)
        lx, ly, lz = rotate(rot, point)
        moved = leash_position(_v3(s, S_REF_POS), _v3(s, S_X), rotate(rot_d, point),
                               (pos[0] + lx, pos[1] + ly, pos[2] + lz))
        if moved is not None:
            s[S_REF_POS], s[S_REF_POS + 1], s[S_REF_POS + 2] = moved
            s[S_X : S_X + 3] = 0.0


@jitable
def region_update(s: Array, p: Array, c: Array) -> None:
    """Algorithm 1, line 14: lock Ω_d on this touch's Ω_i plus the margin (or the user's Ω_d);
    within the onset window grow it to the union of the touch's regions (:mod:`region`)."""
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
    elif not user and s[S_AGE] < p[P_WINDOW] - _WINDOW_SLACK:
        (a, b, cc), (d, e, f) = grow_box((_v3(s, S_BOX), _v3(s, S_BOX + 3)), lo, hi,
                                         p[P_MARGIN])
        s[S_BOX : S_BOX + 6] = np.array((a, b, cc, d, e, f))
    s[S_AGE] += p[P_DT]


@jitable
def velocities(s: Array, p: Array, rot: tuple, pos: tuple, has_rate: bool,
               rate: tuple) -> tuple:
    """(14), (16)–(20) while active: the QP target b_i (20) minus the sliding term of (8), and
    the control velocity ⁰ẋ_cη of (20) [m/s, rad/s] (12 floats)."""
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


@jitable
def graded_response(s: Array, p: Array, vel: tuple, rot: tuple, has_normal: bool,
                    normal: tuple, scale: float, sigma: float) -> tuple:
    """The guard on the commanded velocity: while yielding, the contact centre moves along n̂
    (away from the person) at the yield speed of the excess scale σ (:func:`yield_speed_of`);
    while fading, only s of the motion towards the contact is kept (:func:`limit_approach`)."""
    if not has_normal:
        return vel
    n = rotate(rot, normal)
    if s[S_YIELDING] != 0.0:
        y = yield_speed_of(sigma, p[P_YIELD_SPEED], p[P_YIELD_MAX])
        return (y * n[0], y * n[1], y * n[2], 0.0, 0.0, 0.0,
                y * n[0], y * n[1], y * n[2], 0.0, 0.0, 0.0)
    t = limit_approach((vel[0], vel[1], vel[2]), n, scale)
    u = limit_approach((vel[6], vel[7], vel[8]), n, scale)
    return (t[0], t[1], t[2], vel[3], vel[4], vel[5], u[0], u[1], u[2], vel[9], vel[10], vel[11])


@jitable
def step_task(s: Array, p: Array, phi_gamma: Array, c: Array, rot: tuple, pos: tuple,
              yaw: float, out: Array) -> None:
    """One control step of one link (module docstring) on its state row ``s``.

    Args:
        s, p, phi_gamma: the link's state row (updated), parameter row and ``[Φ Γ]``.
        c: this step's contact row (link frame).
        rot, pos: ⁰R_i (row-major, 9 floats) and ⁰p_γi [m] of the link frame.
        yaw: base heading [rad] (turns the base-frame desired force into the world).
        out: the output row (written).
    """
    in_contact = c[C_IN] != 0.0
    scale, desired_scale, has_normal, normal, sigma = contact_safety(s, p, c, pos)
    has_rate, rate = track_contact(s, p, c)
    w, mu = link_wrench(s, p, c, rot, yaw, desired_scale)
    gated = turn_gate(w, contact_force(c), p[P_TURN_FORCE])
    admittance_step(s, phi_gamma, dead_zone(gated, p[P_DEADBAND_F], p[P_DEADBAND_T]))
    lock = p[P_LOCK]
    psi_raw = lock if not math.isnan(lock) else priority(
        (s[S_V], s[S_V + 1], s[S_V + 2], s[S_V + 3], s[S_V + 4], s[S_V + 5]), p[P_B])
    activating, deactivated, active = advance(s, p, psi_raw, rot, pos)
    if deactivated:
        s[S_X : S_X + 12] = 0.0  # line 10
        reset_region(s)
    if active:
        carry_reference(s, p, rot, pos)
    if active and in_contact:
        region_update(s, p, c)
    vel = (0.0,) * 12
    phase = _INACTIVE
    if active:
        phase = _ACTIVATING if activating else (
            _ACTIVE if in_contact or not math.isnan(lock) else _DEACTIVATING)
        vel = velocities(s, p, rot, pos, has_rate, rate)
    else:
        s[S_X : S_X + 6] = 0.0  # lines 7/10: x_d = x_r = x_γ, so x̃ = 0 by (14)
    if scale < 1.0:
        vel = graded_response(s, p, vel, rot, has_normal, normal, scale, sigma)
    elif s[S_EXHAUSTED] != 0.0:
        # Contact lost past the regain budget: the link stops and waits for a touch (no pull
        # back to the old reference either); a new touch activates the task afresh.
        forget(s)
        vel = (0.0,) * 12
    write_output(s, p, vel, w, rotate(rot, mu), phase, psi_raw, scale, out)
    out[O_YIELD] = s[S_OPENED]


@jitable
def write_output(s: Array, p: Array, vel: tuple, w: tuple, mu_world: tuple, phase: float,
                 psi_raw: float, scale: float, out: Array) -> None:
    """The output row: :class:`TaskOutput`'s 36 values (velocities, wrench, x̃, ẋ̃, ᶦp_η,
    k_η ⁰μ) then phase, ψ (the QP weight: ψ_raw floored at ψ_thr, 1 while yielding), ψ_raw
    and the safety state."""
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
    elif s[S_EXHAUSTED] != 0.0 and has_desired_force(p):
        safety = _LOST
    out[O_SAFETY] = safety


@jitable
def step_links(state: Array, params: Array, phi_gamma: Array, contacts: Array, rots: Array,
               positions: Array, yaw: float, outputs: Array) -> None:
    """:func:`step_task` for every link: row i of ``state``, ``params``, ``phi_gamma`` (k×12×18),
    ``contacts`` (k × N_CONTACT, flat), the link frames ``rots`` (k×9) and ``positions`` (k×3)
    [m]; ``outputs`` (k × N_OUT) written."""
    n_contact = contacts.shape[0] // state.shape[0]
    for i in range(state.shape[0]):
        step_task(state[i], params[i], phi_gamma[i], contacts[n_contact * i : n_contact * (i + 1)],
                  _m9(rots[i], 0), _v3(positions[i], 0), yaw, outputs[i])
