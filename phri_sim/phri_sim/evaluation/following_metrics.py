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
* lag: the shift τ ∈ [−τ_max, τ_max] that maximises the normalised cross-correlation of the
  partner's and the robot's planar velocity, ρ(τ) = Σ_t v_p(t)·v_b(t+τ) / (‖v_p‖‖v_b‖), sums
  and norms over the samples where both shifted series overlap (F7); ``heading_lag`` the same
  for the yaw rates;
  positive τ: the robot moves after the partner. ``None`` when either stands still or the best
  ρ is below :data:`LAG_MIN_CORRELATION` (the motions are unrelated: no lag to speak of);
* travel: planar path length of partner and robot [m] (F8).

:func:`check_bars` holds a summary against the bars of issue 14 (:class:`Bars`).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]

LAG_MIN_CORRELATION = 0.5
"""Below this normalised cross-correlation the lag (F7) is not reported [1]."""


@dataclass(frozen=True)
class Bars:
    """The following bars (issue 14) and the force band.

    Attributes:
        band_low: lower edge of the waist force band [N].
        band_high: upper edge of the waist force band [N].
        band_share_min: least share of the hold with the waist force in the band [1].
        heading_drift_max_deg: largest partner heading drift in the base frame [deg].
        position_drift_rms: largest RMS position drift in the base frame [m].
        position_drift_max: largest position drift in the base frame [m].
        partner_force_max: largest peak contact force on any partner body part [N].
        max_lag: largest |lag| searched by the cross-correlation (F7) [s].
    """

    band_low: float = 2.0
    band_high: float = 25.0
    band_share_min: float = 0.98
    heading_drift_max_deg: float = 10.0
    position_drift_rms: float = 0.05
    position_drift_max: float = 0.10
    partner_force_max: float = 40.0
    max_lag: float = 3.0

    def __post_init__(self) -> None:
        if not 0.0 <= self.band_low < self.band_high:
            raise ValueError(f"band_low={self.band_low} and band_high={self.band_high}: need "
                             "0 <= band_low < band_high [N]")
        if not 0.0 <= self.band_share_min <= 1.0:
            raise ValueError(f"band_share_min={self.band_share_min}: allowed [0, 1]")
        for name in ("heading_drift_max_deg", "position_drift_rms", "position_drift_max",
                     "partner_force_max", "max_lag"):
            if not getattr(self, name) > 0.0:
                raise ValueError(f"{name}={getattr(self, name)}: must be > 0")


TEMPO_BARS = Bars(heading_drift_max_deg=15.0, position_drift_rms=0.08)
"""The bars of the ``tempo`` choreography (issue 14): heading ≤ 15°, position ≤ 8 cm RMS."""


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


def lag(times: FloatArray, leader: FloatArray, follower: FloatArray, max_lag: float
        ) -> tuple[float | None, float]:
    """(τ [s], ρ(τ)) maximising the normalised cross-correlation of the leader's and the
    follower's velocity (finite differences of the (N, d) positions, F7); τ > 0: the follower
    comes later. (``None``, 0) when either velocity is identically zero; (``None``, ρ) when the
    best ρ < :data:`LAG_MIN_CORRELATION`."""
    t = np.asarray(times, dtype=np.float64)
    a = np.asarray(leader, dtype=np.float64).reshape(t.size, -1)
    b = np.asarray(follower, dtype=np.float64).reshape(t.size, -1)
    if t.size < 3:
        return None, 0.0
    dt = float(t[1] - t[0])
    va, vb = np.diff(a, axis=0) / dt, np.diff(b, axis=0) / dt
    na, nb = float(np.sqrt(np.sum(va**2))), float(np.sqrt(np.sum(vb**2)))
    if na < 1e-12 or nb < 1e-12:
        return None, 0.0
    best_k, best = 0, -math.inf
    kmax = min(round(max_lag / dt), va.shape[0] - 1)
    for k in sorted(range(-kmax, kmax + 1), key=abs):  # ties: the smallest shift
        x, y = (va[: va.shape[0] - k], vb[k:]) if k >= 0 else (va[-k:], vb[: vb.shape[0] + k])
        nx, ny = float(np.sqrt(np.sum(x**2))), float(np.sqrt(np.sum(y**2)))
        rho = float(np.sum(x * y)) / (nx * ny) if nx > 1e-12 and ny > 1e-12 else 0.0
        if rho > best + 1e-12:
            best_k, best = k, rho
    return (best_k * dt if best >= LAG_MIN_CORRELATION else None), best


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
    """

    times: FloatArray
    base: FloatArray
    partner: FloatArray
    force: FloatArray
    touched: BoolArray

    def hold_start(self) -> int:
        """Index of the first touched sample (0 if never touched)."""
        on = np.asarray(self.touched, dtype=bool)
        return int(np.argmax(on)) if on.any() else 0


def following_summary(series: FollowingSeries, desired_force: float, bars: Bars = Bars(),
                      peak_forces: dict[str, dict[str, float]] | None = None) -> dict[str, Any]:
    """The ``following`` block of metrics.json (module docstring, F1–F8). ``peak_forces``
    (``{"person": {part: N}, "robot": {link: N}}``) is passed through."""
    h = series.hold_start()
    t = np.asarray(series.times, dtype=np.float64)
    rel = relative_pose(series.base, series.partner)
    lag_s, rho = lag(t[h:], series.partner[h:, :2], series.base[h:, :2], bars.max_lag)
    turn_lag, turn_rho = lag(t[h:], np.unwrap(series.partner[h:, 2]),
                             np.unwrap(series.base[h:, 2]), bars.max_lag)
    out: dict[str, Any] = {
        "hold_start": float(t[h]) if t.size else 0.0,
        "held": bool(np.asarray(series.touched).any()),
        "desired_force": desired_force,
        **drift(rel, h),
        **force_tracking(np.asarray(series.force)[h:], desired_force,
                         (bars.band_low, bars.band_high)),
        "contact_losses": contact_losses(t[h:], np.asarray(series.touched)[h:]),
        "turn": {"partner": accumulated_turn(series.partner[h:, 2]),
                 "robot": accumulated_turn(series.base[h:, 2])},
        "lag": lag_s, "lag_correlation": rho,
        "heading_lag": turn_lag, "heading_lag_correlation": turn_rho,
        "travel": {"partner": travel(series.partner[h:, :2]),
                   "robot": travel(series.base[h:, :2])},
        "bars": asdict(bars),
    }
    if peak_forces is not None:
        out["peak_force"] = peak_forces
    out["pass"] = check_bars(out, bars)
    return out


def check_bars(summary: dict[str, Any], bars: Bars) -> dict[str, bool]:
    """Each bar of :class:`Bars` against a :func:`following_summary` (``all`` = every one).
    Without ``peak_force`` the partner-force bar is not checked (True)."""
    person = summary.get("peak_force", {}).get("person", {})
    result = {
        "band_share": summary["band_share"] >= bars.band_share_min,
        "heading_drift": summary["heading_drift_max_deg"] <= bars.heading_drift_max_deg,
        "position_drift_rms": summary["position_drift_rms"] <= bars.position_drift_rms,
        "position_drift_max": summary["position_drift_max"] <= bars.position_drift_max,
        "partner_force": max(person.values(), default=0.0) <= bars.partner_force_max,
    }
    result["all"] = all(result.values())
    return result
