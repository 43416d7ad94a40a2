"""The per-link task state as rows of floats: the one place a link's state lives.

Each link with an interaction task has three rows, owned by the controller (one row per link in
each of three arrays) and stepped by :func:`~wholebody_controller.task_step.step_task` —
compiled or as plain Python, the same function either way:

* a **state** row (``S_*``, :data:`N_STATE` floats): the admittance (x̃, ẋ̃) of (13)–(14),
  Algorithm 1 (previous ψ, the locked reference x_r), the contact centre ᶦp_η, the contact
  safety (yielding, peak force, regain budget), the desired region Ω_d with its onset window and
  hysteresis triggers. All zeros is the inactive task.
* a **parameter** row (``P_*``, :data:`N_PARAM`): everything the step needs from the
  configuration, filled by :func:`link_params` — the only place a configuration field is mapped
  onto the step.
* ``[Φ Γ]`` of the link's admittance (12×18, :func:`~wholebody_controller.admittance.transition`).

Per step the contact state arrives as a **contact** row (``C_*``) and the step writes an
**output** row (``O_*``): the 36 values of :class:`TaskOutput` then phase, ψ, ψ_raw, safety and
the yield's excess scale σ.
Booleans are 0.0 / 1.0; an unset priority lock is NaN.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np
from numpy.typing import NDArray

from phri_common.records import ContactState
from wholebody_controller.config import ControllerConfig, LinkTaskConfig
from wholebody_controller.contact_safety import Safety
from wholebody_controller.contact_task import Phase, TaskOutput

Array = NDArray[np.float64]

# -- state row --------------------------------------------------------------------------------
S_X, S_V = 0, 6
"""x̃ [m, rad] (6) and ẋ̃ [m/s, rad/s] (6) of (13)–(14): one block of 12 (the admittance)."""
S_PSI_PREV, S_REF_SET, S_REF_ROT, S_REF_POS = 12, 13, 14, 23
"""Algorithm 1: ψ of the previous step; whether x_r is locked; ⁰R_r (9, row-major), ⁰p_r [m]."""
S_POINT, S_HAD = 26, 29
"""ᶦp_η [m] (held after release: the Jacobian point); whether the previous step was touched."""
S_LAST_SET, S_LAST = 30, 31
"""Whether the link frame's previous position is known; ⁰p_γi of the previous step [m]."""
S_YIELDING, S_PEAK, S_TRANSIENT = 34, 35, 36
"""Force guard: yielding; peak contact force since reset [N]; transient limit exceeded."""
S_TRAVEL, S_ELAPSED, S_EXHAUSTED = 37, 38, 39
"""Regain budget: travel [m] and time [s] without contact; the budget is spent."""
S_BOX_SET, S_BOX, S_AGE, S_ENGAGED = 40, 41, 47, 48
"""Ω_d: locked; (min xyz, max xyz) [m]; time since it was locked [s]; the six face triggers."""
S_OPENED = 54
"""The graded yield: how far the whole body's bounds are open, σ held from the yield while the
contact force stays above the fade start (so a joint that left the q_dance band is not driven
back into a partner who still presses)."""
N_STATE = 55

# -- parameter row ----------------------------------------------------------------------------
P_K_ETA, P_B, P_K_P, P_PSI_THR, P_DT = 0, 1, 2, 3, 4
"""k_η [N/m], b [s²/m²], K_p [1/s], ψ_thr, control period [s]."""
P_MARGIN, P_WINDOW, P_HYSTERESIS = 5, 6, 7
"""Ω_d margin [m], onset window [s], face hysteresis [m]."""
P_LOCK, P_DESIRED = 8, 9
"""Priority lock (NaN = automatic (15)); desired force, base frame [N] (3)."""
P_USER_REF_SET, P_USER_REF, P_USER_BOX_SET, P_USER_BOX = 12, 13, 25, 26
"""The user's reference (⁰R_r 9, ⁰p_r 3) and Ω_d (min xyz, max xyz), each with a set flag."""
P_LEAD, P_CARRY = 32, 33
"""Lead moment (F1) on; the reference carried on the leash (F2: lead moment on, K_ω = 0)."""
P_LIMIT, P_TRANSIENT, P_FADE, P_RESET, P_YIELD_SPEED = 34, 35, 36, 37, 38
"""Force limit F and transient limit [N]; fade start a and reset ratio r; yield speed [m/s]."""
P_REGAIN_DISTANCE, P_REGAIN_TIME = 39, 40
"""Regain budget: travel [m] and time [s] a desired force may act without contact."""
P_YIELD_MAX, P_FULL_EXCESS = 41, 42
"""Graded yield: yield speed at the full excess [m/s]; the excess (fraction of F) where σ = 1."""
P_DEADBAND_F, P_DEADBAND_T = 43, 44
"""The admittance input's dead zone (D1): force δ_f [N], torque δ_τ [N·m]."""
P_CARRY_POS = 45
"""The position reference carried on the leash (F3: lead moment on, K_p-stiffness 0)."""
P_TURN_FORCE = 46
"""The contact force F_t [N] above which the admittance's torque input fades (T1; 0 = off)."""
N_PARAM = 47

# -- contact row: in_contact, centre, force, torque, region min, region max (link frame) ------
C_IN, C_CENTER, C_FORCE, C_TORQUE, C_MIN, C_MAX = 0, 1, 4, 7, 10, 13
N_CONTACT = 16

# -- output row: TaskOutput.values (36), then phase, ψ, ψ_raw, safety, σ -----------------------
O_PHASE, O_PSI, O_PSI_RAW, O_SAFETY, O_YIELD = 36, 37, 38, 39, 40
"""``O_YIELD``: how far the link's yield opens the bounds (``S_OPENED``: the yield's largest
excess scale σ, :func:`~wholebody_controller.contact_safety.yield_scale`, held until the force
falls to the fade start); the QP opens the whole body's bounds by the largest."""
N_OUT = 41


def link_params(link: LinkTaskConfig, config: ControllerConfig) -> Array:
    """The parameter row of one link's task: its own settings and the controller-wide ones."""
    p = np.zeros(N_PARAM)
    p[P_K_ETA : P_HYSTERESIS + 1] = (config.k_eta, config.b, config.k_p, config.psi_thr,
                                     config.dt, config.region_margin, config.region_window,
                                     config.region_hysteresis)
    p[P_LOCK] = math.nan if link.priority_lock is None else link.priority_lock
    p[P_DESIRED : P_DESIRED + 3] = link.desired_force
    if link.reference is not None:
        p[P_USER_REF_SET] = 1.0
        p[P_USER_REF : P_USER_REF + 12] = link.reference
    if link.desired_region is not None:
        p[P_USER_BOX_SET] = 1.0
        p[P_USER_BOX : P_USER_BOX + 6] = (*link.desired_region[0], *link.desired_region[1])
    carry = config.lead_moment and not any(link.admittance.stiffness[3:6])
    safety = config.safety
    assert link.force_limit is not None and link.transient_force_limit is not None
    p[P_LEAD : P_FULL_EXCESS + 1] = (config.lead_moment, carry, link.force_limit,
                                     link.transient_force_limit, safety.fade_start,
                                     safety.reset_ratio, safety.yield_speed,
                                     safety.regain_distance, safety.regain_time,
                                     safety.yield_speed_max, safety.full_excess)
    p[P_DEADBAND_F], p[P_DEADBAND_T] = config.force_deadband, config.torque_deadband
    p[P_CARRY_POS] = config.lead_moment and not any(link.admittance.stiffness[0:3])
    p[P_TURN_FORCE] = config.turn_force_limit
    return p


_NO_CONTACT = [0.0] * N_CONTACT


def contact_rows(links: Sequence[str], contacts: Mapping[str, ContactState],
                 ) -> tuple[Array, list[bool]]:
    """This step's contact rows of ``links`` (a missing or untouched link: zeros) and which
    links are touched. ``contacts`` maps link → latest :class:`ContactState`."""
    rows: list[float] = []
    touched = []
    get = contacts.get
    for link in links:
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
    return np.array(rows), touched


_PHASES = tuple(Phase)
_SAFETIES = tuple(Safety)
_make_output = TaskOutput._make  # from a tuple in field order: cheaper than TaskOutput(…)


def task_outputs(links: Sequence[str], outputs: Array, touched: Sequence[bool],
                 ) -> tuple[TaskOutput, ...]:
    """The step's output rows (k × :data:`N_OUT`) as :class:`TaskOutput` records."""
    return tuple(
        _make_output((link, _PHASES[int(row[O_PHASE])], row[O_PSI], row[O_PSI_RAW], hit,
                      tuple(row[:O_PHASE]), _SAFETIES[int(row[O_SAFETY])]))
        for link, row, hit in zip(links, outputs.tolist(), touched, strict=True))
