"""Following a lead through one contact: the lead moment and the carried reference (pure).

Two additions to the paper's contact task (:mod:`~wholebody_controller.contact_task`) that let a
link follow a partner who turns, documented with the measurements that motivated them in
``docs/wholebody_controller.md`` ("Following a turning partner"):

Lead moment. The estimated torque ᶦτ_η of (9b) is taken about the contact centre ᶦp_η, the
pressure's centroid: for a normal-force skin on a straight link it is ≈ 0 whatever the partner
does (Σ (p_k − p_η) × f_k n = 0 for parallel normals n). The lead a partner gives by turning
against the link is *where inside the contact* the pressure goes: a dancer's flat back turned
against a forearm presses harder at one end of the back, and the centroid moves away from the
middle of the contact region Ω_i = [ᶦx⁻, ᶦx⁺] (III-A). Taken about that middle, the estimated force
has the moment::

    ᶦτ_lead = (ᶦp_η − ½(ᶦx⁻ + ᶦx⁺)) × ᶦf_η                                      [N·m]   (F1)

(the rigid-body transfer of the wrench from the centroid to the region's middle). Added to ᶦτ_η in
(12), it turns the link through the rotational admittance (13) towards the end that presses
harder, until the back lies evenly on the link again. A partner who steps *along* the link moves
the region and the centroid together — no moment; that shift is the track force's (11) to answer
by translation. A round waist, one blob whose centroid is its middle, gives no lead at all.

Carried reference. With K = 0 on the rotation, the rotational deflection x̃_ω of (14) integrates
the lead moment without bound, while the robot turns at most at its velocity limit: the desired
orientation ⁰R_d = exp([x̃_ω]×) ⁰R_r runs ahead of the link (measured: 80° ahead after a 20 s
lead, the robot then turning on at its limit long after the lead had stopped), and a dancer's
full turn carries ‖x̃_ω‖ to 2π, where the left Jacobian J_l of (14) is singular. So the
reference is carried along on a leash: whenever ⁰R_d is more than :data:`LEASH_ANGLE` from the
link's orientation ⁰R_i, the reference is re-based onto the leash's end and the deflection
restarts from zero::

    e = log(⁰R_d ⁰R_iᵀ)^∨,   ‖e‖ > ε_ω:   ⁰R_r ← exp(ε_ω e/‖e‖) ⁰R_i,
    ẋ̃_ω ← J_l(x̃_ω) ẋ̃_ω,   x̃_ω ← 0                                                  (F2)

(at the re-base ⁰ω_d = J_l(x̃_ω) ẋ̃_ω of (14) is unchanged; the orientation error K_p e of (19)
stays ≤ K_p ε_ω). A link that keeps up never pulls the leash, so the deflection is also folded
whole into the reference, ⁰R_r ← exp([x̃_ω]×) ⁰R_r (⁰R_d unchanged), whenever ‖x̃_ω‖ passes
:data:`FOLD_ANGLE`, well short of J_l's singularity at 2π. It applies only where the rotational
stiffness is zero (with K ≠ 0 the reference is a spring's rest and must stay).

The translation has the same wind-up: with K = 0 the deflection x̃_p integrates every force
while the robot moves at most at its velocity limit. Measured on a 250 N shove of the waltz
(docs/phri_sim.md, "Shove"): x̃_p ran 0.94 m ahead, the task asked for up to 1.47 m/s against
the 0.15 m/s the base executed, and after the skin had lost the waist the task (its priority
locked) pulled the base on at its limit for 0.6 s, into the partner. So the position reference
is carried on a leash too: whenever the desired contact point leads the link's contact point by
more than :data:`LEASH_DISTANCE`, the reference is re-based onto the leash's end::

    e = (⁰p_r + x̃_p + ⁰R_d ᶦp_η) − (⁰p_γ + ⁰R_i ᶦp_η),   ‖e‖ > ε_p:
    ⁰p_r ← ⁰p_r + x̃_p − (1 − ε_p/‖e‖) e,   x̃_p ← 0                                      (F3)

(ẋ̃_p, the desired point's velocity (16), is unchanged; the position error K_p e of (19) stays
≤ K_p ε_p, so a lost contact pulls the link on by at most ε_p). Where the translational
stiffness is zero.
"""

from __future__ import annotations

import math

from phri_common.jit import jitable
from wholebody_controller.linalg3 import matmul, matmul_transpose, rotate
from wholebody_controller.so3 import Mat9, Vec3, exp, exp_and_left_jacobian, log

LEASH_ANGLE = 0.05
"""ε_ω of (F2): how far the desired orientation may lead the link [rad] (K_p ε_ω = 0.25 rad/s
with the paper's K_p = 5, above every turn rate of the waltz)."""


FOLD_ANGLE = 0.5 * math.pi
"""‖x̃_ω‖ above which the deflection is folded whole into the reference (F2) [rad]."""

LEASH_DISTANCE = 0.06
"""ε_p of (F3): how far the desired contact point may lead the link's [m]. K_p ε_p = 0.3 m/s
with the paper's K_p = 5: about the fastest a contact point moves with the base and the arm
both at Table II's 0.15 limit, so the leash binds only where the robot cannot follow anyway.
Measured (realistic plant, seed 0): 0.03 m held the 20 s shove to 306 N on the abdomen but
raised the sway1 rung's peak to 44.5 N (15.9 without the leash); 0.06 m: 412 N and 16.9 N
(507 N and 15.9 N without)."""


@jitable
def lead_moment(center: Vec3, region_min: Vec3, region_max: Vec3, force: Vec3) -> Vec3:
    """ᶦτ_lead (F1) [N·m]: the moment about the middle of the contact region
    [``region_min``, ``region_max``] [m] of the force ``force`` [N] acting at the contact centre
    ``center`` [m] (all in the link frame)."""
    rx = center[0] - 0.5 * (region_min[0] + region_max[0])
    ry = center[1] - 0.5 * (region_min[1] + region_max[1])
    rz = center[2] - 0.5 * (region_min[2] + region_max[2])
    fx, fy, fz = force
    return (ry * fz - rz * fy, rz * fx - rx * fz, rx * fy - ry * fx)


@jitable
def leash_reference(ref_rot: Mat9, deflection: Vec3, rate: Vec3, rot: Mat9,
                    leash: float = LEASH_ANGLE) -> tuple[Mat9, Vec3] | None:
    """(F2): ``(new ⁰R_r, new ẋ̃_ω [rad/s])`` for a deflection that restarts at 0 when the
    desired orientation exp([x̃_ω]×) ⁰R_r lies more than ``leash`` [rad] from the link's ⁰R_i
    (``rot``: re-based onto the leash's end) or ‖x̃_ω‖ > :data:`FOLD_ANGLE` (folded whole);
    ``None`` otherwise."""
    exp_d, jac_l = exp_and_left_jacobian(deflection)
    desired = matmul(exp_d, ref_rot)
    ex, ey, ez = log(matmul_transpose(desired, rot))
    norm = math.sqrt(ex * ex + ey * ey + ez * ez)
    if norm <= leash:
        dx, dy, dz = deflection
        if dx * dx + dy * dy + dz * dz <= FOLD_ANGLE * FOLD_ANGLE:
            return None
        return desired, rotate(jac_l, rate)
    k = leash / norm
    return matmul(exp((k * ex, k * ey, k * ez)), rot), rotate(jac_l, rate)


@jitable
def leash_position(ref_pos: Vec3, deflection: Vec3, desired_point: Vec3,
                   link_point: Vec3, leash: float = LEASH_DISTANCE) -> Vec3 | None:
    """(F3): the new ⁰p_r [m] for a deflection x̃_p that restarts at 0, when the desired contact
    point ``ref_pos`` + x̃_p + ``desired_point`` (⁰R_d ᶦp_η) lies more than ``leash`` [m] from the
    link's ``link_point`` (⁰p_γ + ⁰R_i ᶦp_η); ``None`` otherwise."""
    ex = ref_pos[0] + deflection[0] + desired_point[0] - link_point[0]
    ey = ref_pos[1] + deflection[1] + desired_point[1] - link_point[1]
    ez = ref_pos[2] + deflection[2] + desired_point[2] - link_point[2]
    norm = math.sqrt(ex * ex + ey * ey + ez * ez)
    if norm <= leash:
        return None
    k = 1.0 - leash / norm
    return (ref_pos[0] + deflection[0] - k * ex, ref_pos[1] + deflection[1] - k * ey,
            ref_pos[2] + deflection[2] - k * ez)
