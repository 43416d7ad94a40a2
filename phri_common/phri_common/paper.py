"""The paper's parameter values, typed once (pure: no ROS, no numpy).

Source: "Beyond the End-Effector" (``/work/shared/paper/beyond-end-effector.md``):

* Table II — joint velocity bounds q̇ ∈ [−0.15, 0.15], k_η = 200, b = 4, K_p = 5, ψ_thr = 10⁻⁴
  (position bounds q ∈ (−∞, +∞): the robot's own limits apply).
* Sec. VI (opening) — 100 Hz control, moving-average window 10 on the taxel data, ε = 0.1 and
  h = 0.15 in the QP (23).
* Sec. III-A — the skin is read at 500 Hz.
* Sec. VI-A.1 (contact centring) — Λ = 0.5 I, D = 40 I, K = 0; estimated torque τ(2) ≤ 1.2.
* Sec. VI-A.2 (contact-change tracking) — Λ = 0.5 I, D = diag(40, 40, 500, 40, 40, 40), K = 0;
  desired-region margin ("redundancy") 0.01 m.
* Sec. VI-A.3 (whole-body pHRI) — Λ = 0.5 I, D = 60 I, K = 40 I.
* Sec. VI-B (waltz) — Λ = 0.1 I, D = 200 I, K = 0; arm joints within q_dance ± 0.1 rad; the left
  forearm's desired force 10 N horizontally to the right in the base frame, its priority locked
  at 1.

Who reads them: the controller's configuration defaults and ``ParamSpec`` lists
(``wholebody_controller.config`` / ``.parameters``), the skin driver's filter window, contact
estimation's torque limit, the simulator bridge's skin rate, the base guard's limits and the arm
bridges' rate (phri_hardware), the phri_sim scenarios (``phri_sim.scenarios.catalogue``) and,
through them, the generated parameter files ``phri_bringup/config/*.yaml`` (``phri params
--write``). ``phri_common/test/test_paper.py`` pins every value against the paper's literals, typed
again from the paper.

Why here: every package that needs one of these values (skin_driver, contact_estimation,
wholebody_controller, phri_sim, phri_bringup, phri_hardware) already depends on phri_common, and
none of them should depend on the controller to learn the skin's filter window.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

Vector6 = tuple[float, float, float, float, float, float]


def six(value: float) -> Vector6:
    """``value · [1 1 1 1 1 1]``: the diagonal of ``value · I₆``."""
    return (value, value, value, value, value, value)


@dataclass(frozen=True)
class Admittance:
    """Diagonals of the admittance matrices of (13), order [x, y, z, rx, ry, rz].

    Attributes:
        inertia: Λ [kg] (translation) / [kg·m²] (rotation).
        damping: D [N·s/m] / [N·m·s/rad].
        stiffness: K [N/m] / [N·m/rad].
    """

    inertia: Vector6
    damping: Vector6
    stiffness: Vector6


# --- Table II --------------------------------------------------------------------------------

VELOCITY_LIMIT = 0.15
"""q̇_u = −q̇_l: bound on every joint velocity [rad/s] and base axis rate [m/s, rad/s]."""
K_ETA = 200.0
"""Track-force gain k_η of (12) [N/m]."""
B = 4.0
"""Priority shape b of (15) [s²/m²]."""
K_P = 5.0
"""Task-space gain K_p of (19) [1/s]."""
PSI_THR = 1e-4
"""Activation threshold ψ_thr of Algorithm 1 and (15) [-]."""

# --- Sec. VI (opening) and III-A -------------------------------------------------------------

CONTROL_RATE_HZ = 100.0
"""Control frequency of every experiment [Hz]."""
EPSILON = 0.1
"""Regularisation ε of the QP (23) [-]."""
HORIZON = 0.15
"""Position-limit horizon h of (22) [s]."""
FILTER_WINDOW = 10
"""Moving-average window applied to the taxel data [frames]."""
SKIN_RATE_HZ = 500.0
"""Rate at which the skin interfaces with the main program [Hz] (III-A)."""

# --- Sec. VI-A: the three basic experiments --------------------------------------------------

CENTRING = Admittance(six(0.5), six(40.0), six(0.0))
"""Contact centring (VI-A.1, Fig. 6): Λ = 0.5 I, D = 40 I, K = 0; also the controller's default."""
TORQUE_LIMIT: tuple[float, float, float] = (math.inf, 1.2, math.inf)
"""Per-axis bound on the estimated torque |τ| in the link frame [N·m] (VI-A.1: τ(2) ≤ 1.2). We
read "(2)" 1-based, as the paper's MATLAB-style indices: the second component, τ_y, the axis the
two-sided press of Fig. 6 loads (link x along the forearm, presses along ±z) and the one Fig. 6b
shows clamped; the other two unbounded."""
TRACKING = Admittance(six(0.5), (40.0, 40.0, 500.0, 40.0, 40.0, 40.0), six(0.0))
"""Contact-change tracking (VI-A.2, Fig. 7): Λ = 0.5 I, D = diag(40, 40, 500, 40, 40, 40), K = 0."""
REGION_MARGIN = 0.01
"""Margin added to the desired contact region Ω_d (VI-A.2) [m]."""
WHOLE_BODY = Admittance(six(0.5), six(60.0), six(40.0))
"""Whole-body pHRI (VI-A.3, Fig. 8): Λ = 0.5 I, D = 60 I, K = 40 I."""

# --- Sec. VI-B: the waltz --------------------------------------------------------------------

WALTZ = Admittance(six(0.1), six(200.0), six(0.0))
"""Waltz (VI-B, Fig. 1): Λ = 0.1 I, D = 200 I, K = 0."""
Q_DANCE_HALF_WIDTH = 0.1
"""Arm joint ranges q_dance ∓ 0.1 [rad]."""
WALTZ_DESIRED_FORCE = 10.0
"""Desired force of the left forearm on the dancer's waist, horizontally to the right in the
base frame, i.e. (0, −10, 0) [N]."""
WALTZ_PRIORITY_LOCK = 1.0
"""The left forearm's priority ψ, locked throughout the dance [-]."""
