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
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from phri_common.params import check_settings, setting

Array = NDArray[np.float64]

GAIN_OFF, SKIN_SILENT = "gain_off", "skin_silent"
"""The verdicts' kinds."""


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


class SkinTorqueCheck:
    """The two checks over time (module docstring); :meth:`update` once per control cycle."""

    def __init__(self, config: TorqueCheckConfig | None = None) -> None:
        self.config = config or TorqueCheckConfig()
        self._since: dict[str, float | None] = {GAIN_OFF: None, SKIN_SILENT: None}
        self.ratio = math.nan
        """ρ of the last update where both views saw a contact (NaN: none yet)."""
        self.residual = math.nan
        """‖τ_ext − ρ τ_skin‖ / ‖τ_ext‖ of that update [-]."""

    def reset(self) -> None:
        """Forget disagreements under way (after a reset of the safe stop)."""
        self._since = {GAIN_OFF: None, SKIN_SILENT: None}

    def update(self, expected: Array, measured: Array, skin_in_contact: bool,
               now: float, backing_off: bool) -> tuple[str, str]:
        """Compare one cycle's views at time ``now`` [s].

        Args:
            expected: τ_skin of the arm's joints [N·m] (:func:`expected_joint_torques`).
            measured: τ_ext of the same joints [N·m] (the external-torque estimate).
            skin_in_contact: whether any skin link reports a contact.
            backing_off: whether the guard against unsensed contacts is stopped and backing
                off (true also where no guard acts): only then can a silent skin be judged.

        Returns:
            ``(kind, message)`` of a verdict (:data:`GAIN_OFF`, :data:`SKIN_SILENT`), or
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
        for kind, holds, hold in ((GAIN_OFF, off, cfg.hold_time),
                                  (SKIN_SILENT, silent, cfg.silent_hold_time)):
            if not holds:
                self._since[kind] = None
                continue
            start = self._since[kind]
            if start is None:
                start = self._since[kind] = now
            if now - start >= hold - 1e-9:
                return kind, self._message(kind, skin_norm, joint_norm, now - start)
        return "", ""

    def _message(self, kind: str, skin: float, joints: float, held: float) -> str:
        cfg = self.config
        if kind == GAIN_OFF:
            return (f"skin gain far off: the skin's contacts explain {1.0 / self.ratio:.2f} × "
                    f"the measured external joint torques (|τ_skin| {skin:.1f} N·m, |τ_ext| "
                    f"{joints:.1f} N·m; allowed 1/{cfg.max_gain_ratio:g}–{cfg.max_gain_ratio:g})"
                    f" for {held:.2f} s")
        return (f"skin silent: the joints feel {joints:.1f} N·m of external torque (≥ "
                f"{cfg.silent_torque:g}) and no skin link reports a contact, while backing off "
                f"for {held:.2f} s")
