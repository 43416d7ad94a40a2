"""Contact safety of one skin link: the force it may cause on a person, and how far it may go
without feeling one (pure).

Force limits (ISO/TS 15066, :mod:`phri_common.iso15066`). Each link has a quasi-static limit F
[N] for the body region it meets. A graded response on the measured contact force ‖f‖:

* ‖f‖ ≤ a·F (``fade_start`` a): normal interaction;
* a·F < ‖f‖ < F: the manual desired force and every commanded motion *towards* the contact (along
  −n̂, n̂ the unit force on the link, which points away from the person) are scaled by
  s = (F − ‖f‖) / ((1 − a) F), falling linearly to 0 at F (:func:`approach_scale`);
* ‖f‖ ≥ F: the link *yields* — it moves away from the contact along n̂, with the highest weight,
  and never towards it — until ‖f‖ falls below r·F (``reset_ratio`` r, hysteresis).

The yield is graded by the excess over F (:func:`yield_scale`): σ = (‖f‖ − F) / (e·F) clipped
into [0, 1] (``full_excess`` e: σ = 1 at (1 + e)·F, by default 2F, the transient limit of most
regions). The yield speed is ``yield_speed`` + σ (``yield_speed_max`` − ``yield_speed``)
(:func:`yield_speed_of`), and the whole body's bounds open with σ while any link yields
(:func:`~wholebody_controller.qp.yield_limits_into`): each arm joint may leave its position range
(the waltz's q_dance band) by up to σ · ``yield_joint_range``, each axis may reach its actuator
limit (``velocity_limits``, not Table II's single ``velocity_limit``), within the rated
``acceleration_limits``. The arm goes first, and alone beyond the normal bounds: the base keeps
its bounds (a fast base turn sweeps the other arm through the partner). The opening is held at
the yield's largest σ until the force falls to the fade start.

The transient limit (2F for most regions) is not a threshold of this response — the response is
already at full yield at F — but the guard records whether it was ever exceeded, for diagnostics.

This module holds the settings and the formulas; the guard's and the budget's state machines
run in the task step (:func:`~wholebody_controller.task_step.guard_update`,
:func:`~wholebody_controller.task_step.regain_update`).

Contact gating. A manual desired force (the waltz's 10 N) acts only while the link is touched.
After contact is lost it may keep acting, to regain the contact, only while the link frame has
travelled less than ``regain_distance`` and less than ``regain_time`` has passed; then it is
switched off until the next touch, the link's task stops (zero target, admittance and reference
reset, so it neither pushes on nor pulls back) and the loss is reported. A blinded skin (no
contact reported while the robot moves) therefore costs at most that distance, never an
open-loop push.
"""

from __future__ import annotations

import enum
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from phri_common import paper
from phri_common.jit import jitable
from phri_common.params import check_settings, setting
from wholebody_controller.so3 import Vec3


class Safety(enum.IntEnum):
    """A link's contact-safety state (reported per link and on diagnostics)."""

    OK = 0
    """Force below the fade start; desired force gated by contact as usual."""
    FADING = 1
    """Force between the fade start and the limit: approach and desired force scaled down."""
    YIELDING = 2
    """Force at or above the limit: the link moves away from the contact (ERROR)."""
    CONTACT_LOST = 3
    """Desired force switched off: contact lost for longer than the regain budget (WARN)."""


@dataclass(frozen=True)
class SafetyConfig:
    """Global settings of the graded response and of contact gating (see module docstring);
    each field is also the node parameter named in its :func:`setting`.

    Attributes:
        fade_start: a, fraction of the limit where fading starts.
        reset_ratio: r, fraction of the limit below which yielding ends.
        yield_speed: speed of the contact centre away from the contact while yielding [m/s].
        regain_distance: link-frame travel allowed without contact under a desired force [m].
        regain_time: time allowed without contact under a desired force [s].
        yield_speed_max: yield speed at the full excess [m/s].
        full_excess: e, the excess over F (fraction of F) where σ reaches 1 [-].
        yield_joint_range: widening of an arm joint's position range at σ = 1 [rad].
    """

    fade_start: float = setting(
        "force_fade_start", 0.5, "fraction of a link's force_limit where desired force and "
        "approach start to fade", "-", 0.0, 0.99, loosens="up")
    reset_ratio: float = setting(
        "force_reset_ratio", 0.5, "fraction of force_limit below which a yielding link resumes",
        "-", 0.01, 1.0, loosens="up")
    yield_speed: float = setting(
        "yield_speed", paper.VELOCITY_LIMIT, "speed of a contact centre away from a contact at "
        "its force_limit", "m/s", 0.0, 1.0, loosens="down")
    regain_distance: float = setting(
        "regain_distance", 0.15, "link travel allowed without contact under a desired force",
        "m", 0.0, 1.0, loosens="up")
    regain_time: float = setting(
        "regain_time", 2.0, "time allowed without contact under a desired force", "s", 0.0, 60.0,
        loosens="up")
    yield_speed_max: float = setting(
        "yield_speed_max", 1.0, "yield speed of a contact centre at the full excess "
        "(1 + yield_full_excess) × force_limit; yield_speed at the limit, linear between", "m/s",
        0.0, 5.0, loosens="down")
    full_excess: float = setting(
        "yield_full_excess", 1.0, "excess over force_limit, as a fraction of it, at which the "
        "yield speed and the whole body's opened bounds are full", "-", 0.01, 100.0,
        loosens="up")
    yield_joint_range: float = setting(
        "yield_joint_range", 0.3, "how far an arm joint may leave its position range (q_dance "
        "band) while a link yields at the full excess (scaled by the excess below it)", "rad",
        0.0, 6.3, loosens="down")

    def __post_init__(self) -> None:
        check_settings(self)


@jitable
def approach_scale(force: float, limit: float, fade_start: float) -> float:
    """s(‖f‖) ∈ [0, 1]: 1 up to a·F, then linear to 0 at F = ``limit`` [N] (``force`` [N])."""
    start = fade_start * limit
    if force <= start:
        return 1.0
    if force >= limit:
        return 0.0
    return (limit - force) / (limit - start)


@jitable
def limit_approach(velocity: Vec3, normal: Vec3, scale: float) -> Vec3:
    """``velocity`` [m/s] with only ``scale`` of its component towards the contact left.

    ``normal`` n̂ is the unit force on the link (away from the person); the part of v along −n̂
    is multiplied by s, the rest of v is kept: ``v − (1 − s) min(v·n̂, 0) n̂``.
    """
    vx, vy, vz = velocity
    nx, ny, nz = normal
    along = vx * nx + vy * ny + vz * nz
    if along >= 0.0:
        return velocity
    k = (1.0 - scale) * along
    return vx - k * nx, vy - k * ny, vz - k * nz


@jitable
def yield_scale(force: float, limit: float, full_excess: float) -> float:
    """σ ∈ [0, 1]: the excess of ``force`` [N] over ``limit`` F [N] as a fraction of
    ``full_excess`` · F (0 at or below F, 1 from (1 + e)·F on)."""
    sigma = (force - limit) / (full_excess * limit)
    if sigma <= 0.0:
        return 0.0
    return sigma if sigma < 1.0 else 1.0


@jitable
def yield_speed_of(sigma: float, yield_speed: float, yield_speed_max: float) -> float:
    """The yield speed [m/s] at excess scale σ: ``yield_speed`` at 0, ``yield_speed_max`` at 1
    (never below ``yield_speed``)."""
    top = yield_speed_max if yield_speed_max > yield_speed else yield_speed
    return yield_speed + sigma * (top - yield_speed)


def safety_changed(known: dict[str, Safety], tasks: Sequence[Any]) -> bool:
    """Update ``known`` (link → :class:`Safety`) from ``tasks`` (each with ``link`` and
    ``safety``); whether any link's state changed (the node publishes diagnostics at once)."""
    changed = False
    for task in tasks:
        if known.get(task.link) is not task.safety:
            known[task.link] = task.safety
            changed = True
    return changed
