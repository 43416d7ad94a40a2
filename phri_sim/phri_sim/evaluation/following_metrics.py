"""Following metrics: how well the robot follows a partner, from what the partner would feel (pure).

Inputs are equally sampled series (one sample per control period) of ground truth that a
recording also carries (docs/phri_sim.md, "Following metrics"):

* the robot base pose (x, y, ψ_b) in ``odom`` [m, rad] (``/odom``);
* the partner's pose (x, y, ψ_p) in ``odom`` (``sim/person/poses``, first pose: the torso);
* the true normal force of the partner on the leading link [N] (``sim/contacts/<link>/wrench``)
  and whether it touches.

From the **start of the hold** (the first sample where the leading link is touched, index h):

* partner pose in the base frame (eq. F1)::

      r(t) = R(−ψ_b) (p(t) − b(t)),   φ(t) = wrap(ψ_p(t) − ψ_b(t))

* position drift d(t) = ‖r(t) − r(h)‖ [m] and heading drift |wrap(φ(t) − φ(h))| [deg]: RMS and
  max over t ≥ t_h (F2). A robot that copies the partner's motion keeps both at zero; a robot
  that stands still sees the partner's own motion (its displacement and turn);
* waist force error |F(t) − F_d| [N]: RMS and max (F3); the share of samples with
  F_lo ≤ F ≤ F_hi (the band, F4);
* contact losses: touched → untouched transitions after t_h, the time to regain each (a loss not
  regained by the end counts to the end and is flagged) (F5);
* accumulated turn of partner and robot: the unwrapped heading's positive (left, counter-
  clockwise) and negative (right) increments summed, [deg] (F6);
* translation and turning lag: the shift τ ∈ [−τ_max, τ_max] that maximises the normalised
  cross-correlation of the partner's and the robot's planar velocities (``translation_lag``),
  resp. yaw rates (``turning_lag``), each smoothed over 0.2 s first
  (:func:`phri_sim.evaluation.partner_feel.rate_lag`, F7); positive τ: the robot moves after the
  partner; ``None`` when either stands still or the best ρ is below 0.5 (unrelated motions);
* travel: planar path length of partner and robot [m] (F8);
* with the robot's commands and measured motion in the series (:class:`FollowingSeries`), what
  the partner feels of it (:mod:`phri_sim.evaluation.partner_feel`, F10–F12): commanded and
  actual base acceleration and jerk, arm joint acceleration, the waist force's fluctuation above
  1 Hz, the time the base takes to rest after each stop of the partner.

:func:`check_bars` holds a summary against bars (:class:`Bars`): :data:`PAPER_TEMPO_BARS` the
pose and force bars at the paper tempo (the followability map's), :data:`WALTZ_BARS` all of the
default waltz's, :data:`TEMPO_BARS` those of the faster rungs, :data:`SWAY_BARS` those with sway.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from phri_sim.evaluation import partner_feel as feel
from phri_sim.world.actuators import BaseDrive

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]

TURN_BAR_MIN_DEG = 30.0
"""The turning-lag bar applies only when the partner turns at least this much (left + right)
[deg]; otherwise it is not applicable."""


@dataclass(frozen=True)
class Bars:
    """Following bars and the force band. A bar set to ``None`` is not checked.

    Attributes:
        band_low: lower edge of the waist force band [N].
        band_high: upper edge of the waist force band [N].
        band_share_min: least share of the hold with the waist force in the band [1].
        heading_drift_max_deg: largest partner heading drift in the base frame [deg].
        position_drift_rms: largest RMS position drift in the base frame [m].
        position_drift_max: largest position drift in the base frame [m].
        partner_force_max: largest peak contact force on any partner body part [N].
        max_lag: largest |lag| searched by the cross-correlation (F7) [s].
        held_share_min: least share of the hold with the waist touched [1].
        turning_lag_max: largest turning lag (F7) [s]; applies when the partner turns
            (:data:`TURN_BAR_MIN_DEG`), and a robot that does not turn with it fails it.
        force_fluctuation_max: largest RMS of the waist force above 1 Hz (F11) [N].
        command_acceleration_max: largest 99th percentile of the commanded base acceleration per
            body-twist axis (F10) [m/s², m/s², rad/s²].
        rest_time_max: longest time to rest after a stop of the partner (F12) [s]; applies when
            the partner stops.
        contact_loss_max: longest contact loss [s].
    """

    band_low: float = 2.0
    band_high: float = 25.0
    band_share_min: float | None = 0.98
    heading_drift_max_deg: float = 10.0
    position_drift_rms: float = 0.05
    position_drift_max: float | None = 0.10
    partner_force_max: float | None = 40.0
    max_lag: float = 3.0
    held_share_min: float | None = None
    turning_lag_max: float | None = None
    force_fluctuation_max: float | None = None
    command_acceleration_max: tuple[float, float, float] | None = None
    rest_time_max: float | None = None
    contact_loss_max: float | None = None

    def __post_init__(self) -> None:
        if not 0.0 <= self.band_low < self.band_high:
            raise ValueError(f"band_low={self.band_low} and band_high={self.band_high}: need "
                             "0 <= band_low < band_high [N]")
        for name in ("band_share_min", "held_share_min"):
            value = getattr(self, name)
            if value is not None and not 0.0 <= value <= 1.0:
                raise ValueError(f"{name}={value}: allowed [0, 1]")
        for name in ("heading_drift_max_deg", "position_drift_rms", "position_drift_max",
                     "partner_force_max", "max_lag", "turning_lag_max", "force_fluctuation_max",
                     "rest_time_max", "contact_loss_max"):
            value = getattr(self, name)
            if value is not None and not value > 0.0:
                raise ValueError(f"{name}={value}: must be > 0")
        accel = self.command_acceleration_max
        if accel is not None and (len(accel) != 3 or not all(a > 0.0 for a in accel)):
            raise ValueError(f"command_acceleration_max={accel}: 3 values > 0 needed")


PAPER_TEMPO_BARS = Bars()
"""The pose and force bars at the paper tempo (the followability map's)."""
RATED_BASE_ACCELERATION = BaseDrive().acceleration
"""The base's rated accelerations (the realistic plant's, :mod:`phri_sim.world.actuators`)."""
WALTZ_BARS = replace(PAPER_TEMPO_BARS, turning_lag_max=0.25, force_fluctuation_max=0.3,
                     command_acceleration_max=RATED_BASE_ACCELERATION, rest_time_max=1.0)
"""Every bar of the default waltz: band ≥ 98 %, drift ≤ 5 cm RMS /
10 cm max, heading ≤ 10°, peak ≤ 40 N, turning lag ≤ 0.25 s, waist force above 1 Hz ≤ 0.3 N
RMS, commanded base acceleration p99 ≤ the rated, at rest within 1 s of the partner stopping."""
TEMPO_BARS = Bars(band_share_min=None, heading_drift_max_deg=15.0, position_drift_rms=0.08,
                  position_drift_max=None, partner_force_max=None, held_share_min=0.95)
"""The faster rungs (×2, ×4 and the ``tempo`` choreography): contact held ≥ 95 %, heading ≤ 15°,
position ≤ 8 cm RMS (and, checked beside the following block, every body part within its ISO/TS
15066 limits)."""
SWAY_BARS = replace(WALTZ_BARS, contact_loss_max=0.5)
"""The default waltz with sway: :data:`WALTZ_BARS` and no contact loss longer than 0.5 s."""
BAR_SETS: dict[str, Bars] = {"paper": PAPER_TEMPO_BARS, "waltz": WALTZ_BARS,
                             "tempo": TEMPO_BARS, "sway": SWAY_BARS}
"""The bar sets by name (a scenario names its own: :attr:`Scenario.bars`)."""


def wrap(angle: FloatArray | float) -> Any:
    """Angle(s) wrapped to [−π, π) [rad]."""
    return (np.asarray(angle) + math.pi) % (2.0 * math.pi) - math.pi


def relative_pose(base: FloatArray, partner: FloatArray) -> FloatArray:
    """Partner pose in the robot base frame (F1): (N, 3) rows (x, y, φ) [m, m, rad] from (N, 3)
    rows (x, y, ψ) of the base and the partner in the same world frame."""
    base, partner = _poses(base, "base"), _poses(partner, "partner")
    if base.shape != partner.shape:
        raise ValueError(f"base has shape {base.shape}, partner {partner.shape}: must match")
    c, s = np.cos(base[:, 2]), np.sin(base[:, 2])
    dx, dy = partner[:, 0] - base[:, 0], partner[:, 1] - base[:, 1]
    return np.column_stack([c * dx + s * dy, -s * dx + c * dy, wrap(partner[:, 2] - base[:, 2])])


def _poses(value: FloatArray, name: str) -> FloatArray:
    arr = np.asarray(value, dtype=np.float64)
    if arr.ndim != 2 or arr.shape[1] != 3:
        raise ValueError(f"{name} poses must have shape (N, 3) (x, y, yaw), got {arr.shape}")
    return arr


def drift(relative: FloatArray, start: int = 0) -> dict[str, float]:
    """Position drift [m] and heading drift [deg] of a relative pose series from its sample
    ``start`` on (F2): RMS and max of each."""
    rel = _poses(relative, "relative")[start:]
    if rel.shape[0] == 0:
        raise ValueError(f"start={start}: no samples from there (series of {len(relative)})")
    pos = np.linalg.norm(rel[:, :2] - rel[0, :2], axis=1)
    head = np.degrees(np.abs(wrap(rel[:, 2] - rel[0, 2])))
    return {
        "position_drift_rms": _rms(pos), "position_drift_max": float(pos.max()),
        "heading_drift_rms_deg": _rms(head), "heading_drift_max_deg": float(head.max()),
    }


def _rms(x: FloatArray) -> float:
    return float(np.sqrt(np.mean(np.square(x)))) if x.size else 0.0


def force_tracking(force: FloatArray, desired: float, band: tuple[float, float]
                   ) -> dict[str, float]:
    """Waist force error against ``desired`` [N] (F3, RMS and max) and the share of samples with
    the force inside ``band`` = (low, high) [N] (F4)."""
    f = np.asarray(force, dtype=np.float64)
    if f.size == 0:
        raise ValueError("force: empty series")
    err = np.abs(f - desired)
    inside = (f >= band[0]) & (f <= band[1])
    return {"force_error_rms": _rms(err), "force_error_max": float(err.max()),
            "band_share": float(inside.mean()), "force_mean": float(f.mean()),
            "force_max": float(f.max()), "force_min": float(f.min())}


def contact_losses(times: FloatArray, touched: BoolArray) -> dict[str, Any]:
    """Touched → untouched transitions and the time until touched again [s] (F5). A loss still
    open at the last sample lasts to it and sets ``unregained``."""
    t = np.asarray(times, dtype=np.float64)
    on = np.asarray(touched, dtype=bool)
    if t.shape != on.shape:
        raise ValueError(f"times {t.shape} and touched {on.shape} must have the same shape")
    gaps: list[float] = []
    lost_at: float | None = None
    for k in range(1, on.size):
        if on[k - 1] and not on[k]:
            lost_at = float(t[k])
        elif on[k] and not on[k - 1] and lost_at is not None:
            gaps.append(float(t[k]) - lost_at)
            lost_at = None
    unregained = lost_at is not None
    if lost_at is not None:
        gaps.append(float(t[-1]) - lost_at)
    return {"count": len(gaps), "time_to_regain_max": max(gaps, default=0.0),
            "time_to_regain_mean": float(np.mean(gaps)) if gaps else 0.0,
            "time_lost": float(sum(gaps)), "unregained": unregained}


def accumulated_turn(yaw: FloatArray) -> dict[str, float]:
    """Left (counter-clockwise, +) and right (clockwise, −, given as a positive number) turn of a
    heading series, summed over its unwrapped increments [deg] (F6), and the net turn."""
    steps = np.diff(np.unwrap(np.asarray(yaw, dtype=np.float64)))
    left = float(np.degrees(steps[steps > 0].sum()))
    right = abs(float(np.degrees(steps[steps < 0].sum())))
    return {"left_deg": left, "right_deg": right, "net_deg": left - right}


def travel(xy: FloatArray) -> float:
    """Planar path length of an (N, 2) position series [m] (F8)."""
    p = np.asarray(xy, dtype=np.float64)
    return float(np.sum(np.linalg.norm(np.diff(p[:, :2], axis=0), axis=1))) if len(p) > 1 else 0.0


@dataclass(frozen=True)
class FollowingSeries:
    """The inputs of :func:`following_summary` (module docstring), one row per sample.

    Attributes:
        times: sample times [s] (equally spaced).
        base: robot base (x, y, ψ_b) in the world [m, rad], (N, 3).
        partner: partner torso (x, y, ψ_p) in the world, (N, 3).
        force: true normal force of the partner on the leading link [N], (N,).
        touched: whether the leading link is touched, (N,).
        twist: measured base body twist (v_x, v_y [m/s], ω [rad/s]), (N, 3) (``/odom``).
        command: commanded base body twist, same units, (N, 3) (``/cmd_vel``).
        arm_velocity: measured arm joint velocities [rad/s], (N, 12) (``/joint_states``).
        arm_command: commanded arm joint velocities [rad/s], (N, 12) (the arms' command topics).
    """

    times: FloatArray
    base: FloatArray
    partner: FloatArray
    force: FloatArray
    touched: BoolArray
    twist: FloatArray | None = None
    command: FloatArray | None = None
    arm_velocity: FloatArray | None = None
    arm_command: FloatArray | None = None

    def hold_start(self) -> int:
        """Index of the first touched sample (0 if never touched)."""
        on = np.asarray(self.touched, dtype=bool)
        return int(np.argmax(on)) if on.any() else 0


def following_summary(series: FollowingSeries, desired_force: float, bars: Bars = Bars(),
                      peak_forces: dict[str, dict[str, float]] | None = None) -> dict[str, Any]:
    """The ``following`` block of metrics.json (module docstring, F1–F12). ``peak_forces``
    (``{"person": {part: N}, "robot": {link: N}}``) is passed through."""
    h = series.hold_start()
    t = np.asarray(series.times, dtype=np.float64)
    rel = relative_pose(series.base, series.partner)
    touched = np.asarray(series.touched, dtype=bool)[h:]
    out: dict[str, Any] = {
        "hold_start": float(t[h]) if t.size else 0.0,
        "held": bool(np.asarray(series.touched).any()),
        "held_share": float(touched.mean()) if touched.size else 0.0,
        "desired_force": desired_force,
        **drift(rel, h),
        **force_tracking(np.asarray(series.force)[h:], desired_force,
                         (bars.band_low, bars.band_high)),
        "contact_losses": contact_losses(t[h:], touched),
        "turn": {"partner": accumulated_turn(series.partner[h:, 2]),
                 "robot": accumulated_turn(series.base[h:, 2])},
        **_lags(t[h:], series.partner[h:], series.base[h:], bars.max_lag),
        "travel": {"partner": travel(series.partner[h:, :2]),
                   "robot": travel(series.base[h:, :2])},
        **_motion(series, h),
        "bars": asdict(bars),
    }
    if peak_forces is not None:
        out["peak_force"] = peak_forces
    out["pass"] = check_bars(out, bars)
    return out


def _lags(t: FloatArray, partner: FloatArray, base: FloatArray, max_lag: float
          ) -> dict[str, Any]:
    """``translation_lag`` and ``turning_lag`` with their correlations (F7)."""
    if t.size < 3:
        return {"translation_lag": None, "translation_lag_correlation": 0.0,
                "turning_lag": None, "turning_lag_correlation": 0.0}
    move, move_rho = feel.rate_lag(t, partner[:, :2], base[:, :2], max_lag)
    turn, turn_rho = feel.rate_lag(t, np.unwrap(partner[:, 2]), np.unwrap(base[:, 2]), max_lag)
    return {"translation_lag": move, "translation_lag_correlation": move_rho,
            "turning_lag": turn, "turning_lag_correlation": turn_rho}


def _motion(series: FollowingSeries, h: int) -> dict[str, Any]:
    """F10–F12 over the hold from what the series carries: ``base_acceleration`` (``commanded``,
    ``actual``), ``arm_acceleration`` (``commanded``, ``actual``), ``force_fluctuation``,
    ``rest``."""
    t = np.asarray(series.times, dtype=np.float64)[h:]
    if t.size < 3:
        return {}
    out: dict[str, Any] = {
        "force_fluctuation": feel.fluctuation(t, np.asarray(series.force)[h:])}
    for key, commanded, actual in (("base_acceleration", series.command, series.twist),
                                   ("arm_acceleration", series.arm_command,
                                    series.arm_velocity)):
        block = {name: feel.derivative_stats(t, np.asarray(v)[h:])
                 for name, v in (("commanded", commanded), ("actual", actual)) if v is not None}
        if block:
            out[key] = block
    if series.command is not None:
        out["yaw_command_fluctuation"] = feel.fluctuation(t, np.asarray(series.command)[h:, 2])
    if series.twist is not None:
        out["rest"] = feel.rest_after_stops(t, series.partner[h:], np.asarray(series.twist)[h:])
    return out


def check_bars(summary: dict[str, Any], bars: Bars) -> dict[str, bool | None]:
    """Each bar of ``bars`` that is set, against a :func:`following_summary`: True (met), False
    (missed) or None (not applicable: no turn for the turning lag, no stop for the rest, no
    measurement in the block); ``all``: no bar missed. Without ``peak_force`` the partner-force
    bar is not applicable."""
    checks: dict[str, bool | None] = {
        "band_share": _at_least(summary.get("band_share"), bars.band_share_min),
        "held_share": _at_least(summary.get("held_share"), bars.held_share_min),
        "heading_drift": _at_most(summary["heading_drift_max_deg"], bars.heading_drift_max_deg),
        "position_drift_rms": _at_most(summary["position_drift_rms"], bars.position_drift_rms),
        "position_drift_max": _at_most(summary["position_drift_max"], bars.position_drift_max),
        "contact_loss": _at_most(summary.get("contact_losses", {}).get("time_to_regain_max"),
                                 bars.contact_loss_max),
        "force_fluctuation": _at_most(summary.get("force_fluctuation", {}).get("rms"),
                                      bars.force_fluctuation_max),
    }
    person = summary.get("peak_force", {}).get("person")
    if bars.partner_force_max is not None:
        checks["partner_force"] = (None if person is None else
                                   max(person.values(), default=0.0) <= bars.partner_force_max)
    if bars.turning_lag_max is not None:
        turned = summary["turn"]["partner"]
        turns = turned["left_deg"] + turned["right_deg"] >= TURN_BAR_MIN_DEG
        lag_s = summary.get("turning_lag")
        checks["turning_lag"] = (None if not turns else
                                 lag_s is not None and bool(abs(lag_s) <= bars.turning_lag_max))
    if bars.command_acceleration_max is not None:
        commanded = summary.get("base_acceleration", {}).get("commanded")
        checks["command_acceleration"] = None if commanded is None else bool(all(
            a <= limit + 1e-9 for a, limit in zip(commanded["p99"],
                                                   bars.command_acceleration_max, strict=True)))
    if bars.rest_time_max is not None:
        rest = summary.get("rest") or {}
        rested = rest.get("time_to_rest_max")
        checks["rest_time"] = (None if not rest.get("stops") else
                               rested is not None and bool(rested <= bars.rest_time_max))
    result = {k: v for k, v in checks.items() if v is not None or _set(bars, k)}
    result["all"] = all(v is not False for v in result.values())
    return result


_BAR_OF = {"band_share": "band_share_min", "held_share": "held_share_min",
           "heading_drift": "heading_drift_max_deg", "position_drift_rms": "position_drift_rms",
           "position_drift_max": "position_drift_max", "contact_loss": "contact_loss_max",
           "force_fluctuation": "force_fluctuation_max", "partner_force": "partner_force_max",
           "turning_lag": "turning_lag_max", "command_acceleration": "command_acceleration_max",
           "rest_time": "rest_time_max"}
"""Check name → the :class:`Bars` field it holds the summary to."""


def _set(bars: Bars, check: str) -> bool:
    return getattr(bars, _BAR_OF[check]) is not None


def _at_least(value: float | None, bar: float | None) -> bool | None:
    return None if bar is None or value is None else bool(value >= bar)


def _at_most(value: float | None, bar: float | None) -> bool | None:
    return None if bar is None or value is None else bool(value <= bar)
