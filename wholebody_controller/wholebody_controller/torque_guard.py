"""The controller's guard against contacts no skin feels: slow, stop, back off (pure, no rclpy).

A contact on an arm link without skin (a wrist, the shoulder, the far side of a link) is felt
only by the arm's joints. :mod:`~wholebody_controller.external_torque` estimates the external
torque on every arm joint from the arms' own readings and subtracts what the skin's contacts
explain; what is left, τ_un, is a contact the controller cannot see. Per arm joint j with its
limit L_j (``unsensed_torque_stop``) the ratio ρ = max_j |τ_un,j| / L_j decides, every control
cycle after the QP (the step itself is unchanged):

* ρ < a (``unsensed_slow_ratio``): **OK**, the command passes unchanged.
* a ≤ ρ < 1: **SLOWING**: every motion *into* the contact is scaled by s = (1 − ρ) / (1 − a),
  reaching 0 at the limit — an arm joint velocity or the yaw rate against its unexplained torque
  (q̇_j τ_un,j < 0), the base's planar velocity's component against its unexplained force (the
  whole base twist when the base reports no force) —; motion *along* the torque (giving way) is
  kept.
* ρ ≥ 1: **STOPPED**: the base stops (zero twist: it cannot sense the contact and must not carry
  the arm on into it), and the arms **back off**: each joint moves along its unexplained torque,
  q̇_j = ``unsensed_backoff_speed`` · clip(τ_un,j / L_j, −1, 1) — the direction that relieves the
  torque — within the joint's position limits, building up at the rated acceleration from the
  previous command (stopping is at once). The interaction tasks are reset on entering (their
  admittance state is what drove the robot into the contact) and on leaving. The guard stays
  STOPPED until ρ has stayed below r (``unsensed_resume_ratio``) for ``unsensed_resume_time``,
  then commands resume from rest.

The robot's own protective stop (a UR stops itself past its force limit: phri_sim's
``world/protective_stop.py``, the real arm's safety system) is the last line; this guard acts
earlier and on the whole robot, the base included. Defaults: :data:`UNSENSED_TORQUE_STOP`.
"""

from __future__ import annotations

import enum
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from phri_common.params import check_settings, setting
from phri_common.planar import world_to_base
from phri_common.records import ContactState
from phri_description.description import JOINT_NAMES
from wholebody_controller.config import ControllerConfig
from wholebody_controller.external_torque import (
    ARM_JOINTS,
    N_Q,
    ArmDynamics,
    ExternalTorqueEstimator,
    unexplained,
)
from wholebody_controller.skin_torque_check import SkinTorqueCheck

FloatArray = NDArray[np.float64]

UNSENSED_TORQUE_STOP: tuple[float, ...] = (60.0, 60.0, 40.0,
                                           *(45.0, 45.0, 22.0, 8.0, 7.0, 4.0) * 2)
"""Default ``unsensed_torque_stop`` in q order: the base's unexplained force along odom x, y
[N] (as a planar norm) and torque about the vertical [N·m], then the arm joints [N·m], left then
right, UR order: 50 N at each joint's longest lever to its arm's far end in the waltz
configuration (side-mounted arms), rounded — shoulder pan 0.90 m, lift 0.91 m, elbow 0.43 m,
wrist 1 0.165 m, wrist 2 0.13 m, wrist 3 0.045 m (4 N·m: a force on the last link loads the
joints before it first). So an unsensed contact stops the robot at about 50 N at the arm's far
end and at less everywhere nearer a joint — half the abdomen's 110 N (ISO/TS 15066) — while the
normal dance leaves a tenth of these unexplained (docs/wholebody_controller.md, "Contacts no
skin feels"). The base: 60 N, a bit over the abdomen's half (the base's own estimate carries the
mass of the whole robot: measured noise in the dance below 7 N), and 40 N·m about the vertical
(60 N at 0.65 m from the base's centre)."""


@dataclass(frozen=True)
class TorqueGuardConfig:
    """The guard's settings (module docstring); each field is a node parameter."""

    enabled: bool = setting(
        "unsensed_guard", True, "guard against contacts no skin feels: slow, stop and back off "
        "on the external joint torques and base forces no skin contact explains (false: "
        "estimate and report only)")
    stop_torques: tuple[float, ...] = setting(
        "unsensed_torque_stop", UNSENSED_TORQUE_STOP, "unexplained external force/torque of "
        "each axis in q order (base x, y as a planar norm, yaw, left then right arm joints) at "
        "which the robot stops and backs off", "N or N·m", 0.1, 10000.0, length=15)
    slow_ratio: float = setting(
        "unsensed_slow_ratio", 0.5, "fraction of unsensed_torque_stop from which the motion into "
        "the contact is slowed", "-", 0.0, 0.99)
    resume_ratio: float = setting(
        "unsensed_resume_ratio", 0.3, "fraction of unsensed_torque_stop below which a stopped "
        "robot resumes (after unsensed_resume_time)", "-", 0.0, 0.99)
    resume_time: float = setting(
        "unsensed_resume_time", 0.5, "the torque must stay below the resume ratio this long "
        "before a stopped robot resumes", "s", 0.0, 60.0)
    backoff_speed: float = setting(
        "unsensed_backoff_speed", 0.1, "largest speed of each axis backing off along its "
        "unexplained force or torque while stopped", "rad/s or m/s", 0.0, 1.0)
    filter_time: float = setting(
        "external_torque_filter_time", 0.02, "time constant of the low-pass on the estimated "
        "external joint torques and base forces", "s", 0.0, 1.0)

    def __post_init__(self) -> None:
        check_settings(self)
        if self.resume_ratio > self.slow_ratio:
            raise ValueError(f"parameter 'unsensed_resume_ratio' = {self.resume_ratio} must be ≤ "
                             f"'unsensed_slow_ratio' = {self.slow_ratio}")


class GuardState(enum.IntEnum):
    """The guard's state (reported on diagnostics)."""

    OK = 0
    SLOWING = 1
    STOPPED = 2


@dataclass
class GuardReport:
    """What the guard saw and did in the last cycle (diagnostics).

    Attributes:
        state: :class:`GuardState`.
        ratio: ρ = max_j |τ_un,j| / L_j (base x, y: the planar norm).
        joint: the axis of the largest ratio (a joint name of q; ``base_x`` for the planar
            force).
        torque: its unexplained torque [N·m]; limit: its L_j [N·m].
        scale: the slowing factor applied (1: none).
        stops: times the guard stopped the robot.
        slowed: control cycles it slowed the robot.
        peak_ratio: the largest ρ seen.
        sensed: whether every axis reports an effort (else those axes are unguarded).
        unsensed: the axes without an effort reading.
        external: τ_ext of the 15 axes [N, N·m]; skin: the skin's share [N, N·m].
    """

    state: GuardState = GuardState.OK
    ratio: float = 0.0
    joint: str = ""
    torque: float = 0.0
    limit: float = 0.0
    scale: float = 1.0
    stops: int = 0
    slowed: int = 0
    peak_ratio: float = 0.0
    sensed: bool = False
    unsensed: tuple[str, ...] = JOINT_NAMES
    external: FloatArray = field(default_factory=lambda: np.zeros(N_Q))
    skin: FloatArray = field(default_factory=lambda: np.zeros(N_Q))


def axis_ratios(tau: FloatArray, limits: FloatArray) -> FloatArray:
    """|τ_un| / L per axis (15, q order); the base's x and y both carry the planar norm
    ‖(τ_x / L_x, τ_y / L_y)‖."""
    ratios = np.abs(tau) / limits
    ratios[0] = ratios[1] = math.hypot(float(ratios[0]), float(ratios[1]))
    return np.asarray(ratios)


def slow_command(command: FloatArray, tau: FloatArray, scale: float, yaw: float) -> FloatArray:
    """SLOWING (module docstring): ``command`` (15; the base's part a base-frame twist) with
    every motion into the contact scaled by ``scale``: each arm joint velocity and the yaw rate
    against its own unexplained torque (``tau``, 15, q order), and the base's planar velocity's
    component against the unexplained planar force (world frame, turned into the base frame at
    ``yaw``); a base whose drives report no force (τ_x = τ_y = 0) has its whole twist scaled."""
    out = np.array(command, dtype=np.float64)
    fx, fy = world_to_base(yaw, float(tau[0]), float(tau[1]))
    norm = math.hypot(fx, fy)
    if norm == 0.0 and tau[2] == 0.0:
        out[:3] *= scale
    else:
        if norm > 0.0:
            along = (out[0] * fx + out[1] * fy) / norm
            if along < 0.0:
                out[0] -= (1.0 - scale) * along * fx / norm
                out[1] -= (1.0 - scale) * along * fy / norm
        if out[2] * tau[2] < 0.0:
            out[2] *= scale
    arms = out[3:]
    against = arms * tau[3:] < 0.0
    arms[against] *= scale
    return out


def backoff_command(tau: FloatArray, limits: FloatArray, speed: float, q: FloatArray,
                    position_limits: FloatArray, previous: FloatArray, step: FloatArray,
                    horizon: float) -> FloatArray:
    """STOPPED (module docstring): every axis along its unexplained force or torque ``tau``
    (15, q order) at ``speed`` · clip(τ/L, −1, 1) [m/s, rad/s] — the base's planar part along
    the planar force, turned into the base frame at the yaw ``q[2]`` — zero where that would
    leave the joint's ``position_limits`` (15×2) within ``horizon`` [s]; a speed builds up within
    ± ``step`` (15: rated acceleration × dt) of the ``previous`` command (15), a stop is at once
    (the interval always holds zero: the drives brake at their own limit, as on a zero command
    after stale input)."""
    share = tau / limits
    velocity = speed * np.clip(share, -1.0, 1.0)
    velocity[:2] = speed * share[:2] / max(1.0, math.hypot(float(share[0]), float(share[1])))
    velocity[0], velocity[1] = world_to_base(float(q[2]), float(velocity[0]), float(velocity[1]))
    ahead = q + horizon * velocity
    inside = (ahead >= position_limits[:, 0]) & (ahead <= position_limits[:, 1])
    velocity[3:] = np.where(inside[3:], velocity[3:], 0.0)
    low = np.minimum(previous - step, 0.0)
    high = np.maximum(previous + step, 0.0)
    return np.asarray(np.clip(velocity, low, high))


class GuardedController(Protocol):
    """What :meth:`TorqueWatch.apply` needs of the controller (``WholeBodyController``)."""

    previous_command: FloatArray
    limits: FloatArray
    config: ControllerConfig

    def reset(self) -> None: ...


class TorqueWatch:
    """The estimator and the guard the node runs (module docstring).

    Args:
        config: the guard's settings.
        position_limits: (15, 2) hard position limits of q [m, rad] (the base's x, y
            unbounded).
        dynamics: the rigid-body model (default: the robot description's).
    """

    def __init__(self, config: TorqueGuardConfig, position_limits: FloatArray,
                 dynamics: ArmDynamics | None = None) -> None:
        self.estimator = ExternalTorqueEstimator(dynamics or ArmDynamics(), config.filter_time)
        self.position_limits = np.asarray(position_limits, dtype=np.float64)
        self.config = config
        self.report = GuardReport()
        self._clear_since = math.nan
        self.changed = False
        """Whether the last :meth:`apply` changed the guard's state (diagnostics at once)."""

    @property
    def config(self) -> TorqueGuardConfig:
        return self._config

    @config.setter
    def config(self, config: TorqueGuardConfig) -> None:
        self._config = config
        self._limits = np.asarray(config.stop_torques, dtype=np.float64)
        self.estimator.filter_time = config.filter_time

    def apply(self, controller: GuardedController, t: float, command: FloatArray,
              q: FloatArray, contacts: Mapping[str, ContactState]) -> FloatArray:
        """:meth:`command` for ``controller``'s step: its tasks reset when the guard stops the
        robot and again when it resumes (what they integrated meanwhile was never executed), and
        the command sent kept as its previous command (the next QP's acceleration bound starts
        from what the robot was told)."""
        state = self.report.state
        out, stopped = self.command(t, command, q, contacts, controller.previous_command,
                                    controller.limits[4], controller.config.horizon)
        resumed = state is GuardState.STOPPED and self.report.state is not GuardState.STOPPED
        if stopped or resumed:
            controller.reset()
        controller.previous_command[...] = out
        self.changed = self.report.state is not state
        return out

    def judge_skin(self, check: SkinTorqueCheck, contacts: Mapping[str, ContactState],
                   t: float) -> tuple[str, str]:
        """The skin against the joints at time ``t`` [s], after this cycle's :meth:`apply`
        (:class:`SkinTorqueCheck`): the arm joints' skin share and measured τ_ext, the skin
        links reporting a contact (force, centre: the frozen check), and whether this guard is
        backing off (always true with the guard off: nothing else would back away).
        ``("", "")`` and the check's hold times restarted while an arm joint reports no effort
        or ``skin_torque_check`` is off."""
        report = self.report
        if not check.config.enabled or any(n in ARM_JOINTS for n in report.unsensed):
            check.reset()
            return "", ""
        shares = self.estimator.dynamics.link_torques  # this cycle's, from command()
        readings = {link: (float(np.linalg.norm(state.force)), state.center, shares[link][3:])
                    for link, state in contacts.items() if state.in_contact and link in shares}
        backing_off = report.state is GuardState.STOPPED or not self.config.enabled
        return check.update(report.skin[3:], report.external[3:], bool(readings), t,
                            backing_off, readings)

    def command(self, t: float, command: FloatArray, q: FloatArray,
                contacts: Mapping[str, ContactState], previous: FloatArray, step: FloatArray,
                horizon: float) -> tuple[FloatArray, bool]:
        """This cycle's command at time ``t`` [s]: the QP's ``command`` (15) passed, slowed or
        replaced by the back-off (module docstring), and whether the guard has just stopped the
        robot (the caller resets the tasks). ``previous``: the last command sent; ``step``: the
        rated acceleration × dt of each axis; ``horizon``: the QP's h [s]."""
        est, report, c = self.estimator, self.report, self.config
        skin = est.skin(q, contacts)
        tau = unexplained(est.tau, skin)
        ratios = axis_ratios(tau, self._limits)
        worst = int(np.argmax(ratios))
        rho = float(ratios[worst])
        report.ratio, report.joint = rho, JOINT_NAMES[worst]
        report.torque, report.limit = float(tau[worst]), float(self._limits[worst])
        report.peak_ratio = max(report.peak_ratio, rho)
        report.sensed = bool(np.all(est.sensed))
        report.unsensed = tuple(n for n, s in zip(JOINT_NAMES, est.sensed, strict=True) if not s)
        report.external, report.skin = est.tau.copy(), skin
        report.scale = 1.0
        if not c.enabled:
            report.state = GuardState.OK
            return command, False
        stopped_now = self._transition(t, rho)
        if report.state is GuardState.STOPPED:
            return backoff_command(tau, self._limits, c.backoff_speed, q, self.position_limits,
                                   previous, step, horizon), stopped_now
        if report.state is GuardState.SLOWING:
            report.slowed += 1
            report.scale = (1.0 - rho) / (1.0 - c.slow_ratio)
            return slow_command(command, tau, report.scale, float(q[2])), False
        return command, False

    def _transition(self, t: float, rho: float) -> bool:
        """The state after ratio ``rho`` at time ``t``; True when it has just become STOPPED."""
        report, c = self.report, self.config
        if report.state is GuardState.STOPPED:
            if rho >= c.resume_ratio:
                self._clear_since = math.nan
                return False
            if math.isnan(self._clear_since):
                self._clear_since = t
            if t - self._clear_since < c.resume_time - 1e-9:
                return False
        if rho >= 1.0:
            was = report.state
            report.state = GuardState.STOPPED
            self._clear_since = math.nan
            if was is not GuardState.STOPPED:
                report.stops += 1
                return True
            return False
        report.state = GuardState.SLOWING if rho >= c.slow_ratio else GuardState.OK
        return False


__all__ = ["UNSENSED_TORQUE_STOP", "GuardReport", "GuardState", "TorqueGuardConfig",
           "TorqueWatch", "axis_ratios", "backoff_command", "slow_command"]
