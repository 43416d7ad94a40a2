"""Does the skin agree with the joints? Checks of the skin against an external-torque estimate
(pure, no rclpy).

The skin reports, per link, a contact force ᶦf_η at the contact centre ᶦp_η and a torque ᶦτ_η
about it. What those contacts do to the arm's joints is, with the contact-centre Jacobians J_i
of (8) (world frame, [linear; angular], the arm's columns),

    τ_skin = Σ_i J_iᵀ ⁰w_i,     ⁰w_i = [⁰R_i ᶦf_η; ⁰R_i ᶦτ_η]          [N·m]

(:func:`expected_joint_torques`). An external-torque estimate τ_ext from the joints (motor
currents or joint efforts less the model's gravity, Coriolis and inertia terms; another module)
measures the same quantity independently, in the same convention: the torque the external
forces exert at each joint. Two lies of the skin show in their disagreement
(:class:`SkinTorqueCheck`):

* **gain far off**: both see a contact (‖τ_skin‖ and ‖τ_ext‖ ≥ ``min_torque``), the scaled
  skin explains the measured torques (fit residual e = ‖τ_ext − ρ τ_skin‖ / ‖τ_ext‖ ≤
  ``max_residual``: a wrong gain keeps the direction of τ in joint space, another contact on an
  unsensed link does not) and the least-squares scale ρ = τ_extᵀ τ_skin / τ_skinᵀ τ_skin of the
  skin's torques onto the measured ones lies outside [1/``max_gain_ratio``, ``max_gain_ratio``]
  — a skin reading 3 × the force gives ρ = 1/3, one reading 0.3 × gives ρ = 3.3 — for
  ``hold_time``;
* **skin silent**: the joints feel a contact (‖τ_ext‖ ≥ ``silent_torque``) while no skin link
  reports one and the guard against unsensed contacts (:mod:`~wholebody_controller.torque_guard`)
  is stopped and backing off, for ``silent_hold_time``. A contact where there is no skin looks
  the same as a blinded skin; it is the guard's (slow, stop, back off, resume) as long as
  backing off relieves it, and a latched stop would freeze the robot in the pinch instead. Only
  a contact the back-off does not relieve (or any, with the guard switched off) is a verdict.

A verdict is a safe stop (:mod:`~wholebody_controller.safe_stop`): diagnostics ERROR and an
exact zero command until reset. The hold times keep one noisy estimate, or a contact landing
between two skin frames, from stopping the robot. Sizes are the arm's joints only (the base has
no torque sensing); ``τ_skin`` and ``τ_ext`` must name the same joints in the same order.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from phri_common.params import check_settings, setting

Array = NDArray[np.float64]

GAIN_OFF, SKIN_SILENT, SKIN_FROZEN = "gain_off", "skin_silent", "skin_frozen"
"""The verdicts' kinds."""
VERDICTS = (GAIN_OFF, SKIN_SILENT, SKIN_FROZEN)


@dataclass(frozen=True)
class TorqueCheckConfig:
    """Settings of :class:`SkinTorqueCheck` (module docstring); each field is a node parameter,
    protected (:mod:`phri_common.protected`: loosening one at run time needs the unlock)."""

    enabled: bool = setting(
        "skin_torque_check", True, "check the skin against the external joint torques (gain far "
        "off, skin silent) and trip the safe stop on a verdict (false: not checked)",
        loosens="down")
    max_gain_ratio: float = setting(
        "skin_max_gain_ratio", 2.0, "largest plausible ratio between the skin's and the joints' "
        "view of a contact (the least-squares gain ρ must lie in [1/r, r])", "-", 1.0, 100.0,
        loosens="up")
    min_torque: float = setting(
        "skin_min_torque", 3.0, "both views' arm-joint torque norms must reach this for the "
        "gain to be judged", "N·m", 0.0, 1000.0, loosens="up")
    max_residual: float = setting(
        "skin_max_residual", 0.5, "the gain is judged only while the scaled skin explains the "
        "measured torques: ‖τ_ext − ρ τ_skin‖ ≤ this × ‖τ_ext‖ (a worse fit is another, "
        "unsensed contact: the torque guard's)", "-", 0.0, 1.0, loosens="up")
    hold_time: float = setting(
        "skin_gain_hold_time", 0.3, "how long the gain must stay far off to be a verdict", "s",
        0.0, 10.0, loosens="up")
    silent_torque: float = setting(
        "skin_silent_torque", 8.0, "arm-joint external torque norm that means contact while no "
        "skin link reports one", "N·m", 0.0, 1000.0, loosens="up")
    silent_hold_time: float = setting(
        "skin_silent_hold_time", 2.0, "how long the joints must feel a contact no skin reports "
        "while the unsensed guard is stopped and backing off (always, with the guard off) to be "
        "a verdict: a contact backing off does not relieve", "s", 0.0, 60.0, loosens="up")
    still_force_ratio: float = setting(
        "skin_still_force_ratio", 0.05, "a skin link's contact is still while its force stays "
        "within this fraction of its force when the stillness began", "-", 0.0, 1.0,
        loosens="down")
    still_center_range: float = setting(
        "skin_still_center_range", 2e-3, "… and its contact centre within this of where it "
        "was, on every axis", "m", 0.0, 1.0, loosens="down")
    frozen_torque: float = setting(
        "skin_frozen_torque", 3.0, "change of the torque the skin does not explain (τ_ext − "
        "τ_skin, along the skin's contact) since the skin became still that makes the still "
        "skin frozen", "N·m", 0.0, 1000.0, loosens="up")
    frozen_hold_time: float = setting(
        "skin_frozen_hold_time", 0.3, "how long a still skin must disagree with the joints' "
        "change to be a verdict", "s", 0.0, 10.0, loosens="up")

    def __post_init__(self) -> None:
        check_settings(self)


def expected_joint_torques(jacobians: Sequence[Array], wrenches: Sequence[Array]) -> Array:
    """τ_skin = Σ J_iᵀ w_i [N·m]: each skin link's contact wrench w_i (world, [force N;
    torque N·m] at the contact centre) through its contact-centre Jacobian J_i (6×n, world,
    [linear; angular], the columns of the joints compared)."""
    if len(jacobians) != len(wrenches):
        raise ValueError(f"{len(jacobians)} Jacobians for {len(wrenches)} wrenches")
    if not jacobians:
        raise ValueError("no skin link: nothing to compare")
    total = np.zeros(np.asarray(jacobians[0]).shape[1])
    for jac, wrench in zip(jacobians, wrenches, strict=True):
        total += np.asarray(jac, dtype=np.float64).T @ np.asarray(wrench, dtype=np.float64)
    return total


def gain_ratio(expected: Array, measured: Array) -> float:
    """ρ = τ_extᵀ τ_skin / τ_skinᵀ τ_skin: the scale that best maps the skin's joint torques
    onto the measured ones (1: they agree; NaN when the skin's are zero)."""
    norm2 = float(expected @ expected)
    if norm2 == 0.0:
        return math.nan
    return float(measured @ expected) / norm2


Reading = tuple[float, Sequence[float], Array]
"""A skin link's contact: its force magnitude [N] and centre (x, y, z) [m] in the link frame,
and what it does to the compared joints, Jᵀ w [N·m] (its share of τ_skin)."""


class SkinStillness:
    """Since when each skin link's contact has been still (module docstring, "skin frozen").

    A link is still while it stays in contact with its force f within ``force_ratio`` · f₀ of,
    and its centre within ``center_range`` [m] (every axis) of, its reading f₀, c₀ when the
    stillness began. O(links) per update.
    """

    def __init__(self, force_ratio: float, center_range: float) -> None:
        self.force_ratio, self.center_range = force_ratio, center_range
        self._start: dict[str, tuple[float, tuple[float, ...]]] = {}
        self.since: dict[str, float] = {}
        """When each link in contact became still [s]."""

    def reset(self) -> None:
        """Forget the stillness under way."""
        self._start, self.since = {}, {}

    def update(self, readings: Mapping[str, Reading], now: float) -> list[str]:
        """Take the links in contact at ``now`` [s]; the links whose stillness begins here (a
        new contact, or one that moved or changed its force). A link released is forgotten."""
        for link in [link for link in self._start if link not in readings]:
            del self._start[link], self.since[link]
        begun = []
        for link, (force, center, _) in readings.items():
            start = self._start.get(link)
            if start is not None and abs(force - start[0]) <= self.force_ratio * start[0] and all(
                    abs(x - x0) <= self.center_range for x, x0 in zip(center, start[1],
                                                                      strict=True)):
                continue
            self._start[link] = (float(force), tuple(float(x) for x in center))
            self.since[link] = now
            begun.append(link)
        return begun


class SkinTorqueCheck:
    """The two checks over time (module docstring); :meth:`update` once per control cycle."""

    def __init__(self, config: TorqueCheckConfig | None = None) -> None:
        self.config = config or TorqueCheckConfig()
        self._since: dict[str, float | None] = dict.fromkeys(VERDICTS)
        self.stillness = SkinStillness(self.config.still_force_ratio,
                                       self.config.still_center_range)
        self._still_start: dict[str, Array] = {}
        self.still_change = math.nan
        """The largest ‖Δu‖ of a still link at the last update [N·m] (NaN: no link in contact;
        module docstring)."""
        self.still_time = 0.0
        """How long that link has been still [s]."""
        self.frozen_link: tuple[str, float, float] = ("", 0.0, 0.0)
        """The last link found frozen: its name, ‖Δu‖ [N·m], how long it had been still [s]."""
        self.ratio = math.nan
        """ρ of the last update where both views saw a contact (NaN: none yet)."""
        self.residual = math.nan
        """‖τ_ext − ρ τ_skin‖ / ‖τ_ext‖ of that update [-]."""

    def reset(self) -> None:
        """Forget disagreements under way (after a reset of the safe stop)."""
        self._since = dict.fromkeys(VERDICTS)
        self.stillness.reset()
        self._still_start = {}
        self.still_change = math.nan

    def update(self, expected: Array, measured: Array, skin_in_contact: bool,
               now: float, backing_off: bool,
               readings: Mapping[str, Reading] | None = None) -> tuple[str, str]:
        """Compare one cycle's views at time ``now`` [s].

        Args:
            expected: τ_skin of the arm's joints [N·m] (:func:`expected_joint_torques`).
            measured: τ_ext of the same joints [N·m] (the external-torque estimate).
            skin_in_contact: whether any skin link reports a contact.
            backing_off: whether the guard against unsensed contacts is stopped and backing
                off (true also where no guard acts): only then can a silent skin be judged.
            readings: the skin links in contact (:data:`Reading`), for the frozen check
                (``None``: not judged).

        Returns:
            ``(kind, message)`` of a verdict (:data:`GAIN_OFF`, :data:`SKIN_SILENT`,
            :data:`SKIN_FROZEN`), or
            ``("", "")`` while they agree or a disagreement is younger than its hold time.

        Raises:
            ValueError: the sizes differ or a value is not finite.
        """
        expected = np.asarray(expected, dtype=np.float64)
        measured = np.asarray(measured, dtype=np.float64)
        if expected.shape != measured.shape or not (
                np.all(np.isfinite(expected)) and np.all(np.isfinite(measured))):
            raise ValueError(f"skin torques {expected.shape} and measured {measured.shape} "
                             "must be finite and of one size")
        cfg = self.config
        skin_norm, joint_norm = float(np.linalg.norm(expected)), float(np.linalg.norm(measured))
        off = False
        if skin_norm >= cfg.min_torque and joint_norm >= cfg.min_torque:
            self.ratio = gain_ratio(expected, measured)
            self.residual = float(np.linalg.norm(measured - self.ratio * expected)) / joint_norm
            off = self.residual <= cfg.max_residual and not (
                1.0 / cfg.max_gain_ratio <= self.ratio <= cfg.max_gain_ratio)
        silent = not skin_in_contact and joint_norm >= cfg.silent_torque and backing_off
        frozen = readings is not None and self._frozen(expected, measured, readings, now)
        for kind, holds, hold in ((GAIN_OFF, off, cfg.hold_time),
                                  (SKIN_SILENT, silent, cfg.silent_hold_time),
                                  (SKIN_FROZEN, frozen, cfg.frozen_hold_time)):
            if not holds:
                self._since[kind] = None
                continue
            start = self._since[kind]
            if start is None:
                start = self._since[kind] = now
            if now - start >= hold - 1e-9:
                return kind, self._message(kind, skin_norm, joint_norm, now - start)
        return "", ""

    def _frozen(self, expected: Array, measured: Array, readings: Mapping[str, Reading],
                now: float) -> bool:
        """Whether a skin link is still while the torque the skin does not explain,
        u = τ_ext − τ_skin [N·m], has changed since that link became still by ‖Δu‖ ≥
        ``frozen_torque`` along the link's own share τ_i of τ_skin (‖Δu − κ τ_i‖ ≤
        ``max_residual`` ‖Δu‖, κ = Δuᵀ τ_i / τ_iᵀ τ_i; module docstring). The other links'
        changes, read by their skin, are in both τ_ext and τ_skin: they leave u alone."""
        cfg, still = self.config, self.stillness
        still.force_ratio, still.center_range = cfg.still_force_ratio, cfg.still_center_range
        unexplained = measured - expected
        for link in still.update(readings, now):
            self._still_start[link] = unexplained
        for link in [link for link in self._still_start if link not in still.since]:
            del self._still_start[link]
        self.still_change, self.still_time, frozen = math.nan, 0.0, False
        for link, since in still.since.items():
            change = unexplained - self._still_start[link]
            size = float(np.linalg.norm(change))
            if not size <= self.still_change:  # the largest change reported (NaN: none yet)
                self.still_change, self.still_time = size, now - since
            kappa = gain_ratio(readings[link][2], change)
            if size >= cfg.frozen_torque and size > 0.0 and not math.isnan(kappa) and float(
                    np.linalg.norm(change - kappa * readings[link][2])) <= cfg.max_residual * size:
                frozen, self.frozen_link = True, (link, size, now - since)
        return frozen

    def _message(self, kind: str, skin: float, joints: float, held: float) -> str:
        cfg = self.config
        if kind == SKIN_FROZEN:
            link, change, still = self.frozen_link
            return (f"skin frozen: {link}'s contact has stayed still (within "
                    f"{100 * cfg.still_force_ratio:g} % and {1e3 * cfg.still_center_range:g} mm)"
                    f" for {still:.2f} s while the torque the skin does not explain changed by "
                    f"{change:.1f} N·m along that contact (allowed {cfg.frozen_torque:g}: "
                    f"skin_frozen_torque) for {held:.2f} s")
        if kind == GAIN_OFF:
            return (f"skin gain far off: the skin's contacts explain {1.0 / self.ratio:.2f} × "
                    f"the measured external joint torques (|τ_skin| {skin:.1f} N·m, |τ_ext| "
                    f"{joints:.1f} N·m; allowed 1/{cfg.max_gain_ratio:g}–{cfg.max_gain_ratio:g})"
                    f" for {held:.2f} s")
        return (f"skin silent: the joints feel {joints:.1f} N·m of external torque (≥ "
                f"{cfg.silent_torque:g}) and no skin link reports a contact, while backing off "
                f"for {held:.2f} s")
