"""Per-scenario metrics from a run (pure, no rclpy).

:class:`MetricsRecorder` samples the simulation once per control period (ground truth, robot
state, the command the servos follow) together with the contact states the estimator published,
and :meth:`MetricsRecorder.summary` reduces them to the scenario's JSON metrics:

* every scenario: per skin link the share of time touched and peak / mean true normal force
  while touched; ``limit_violations`` = control periods in which

  - a joint was beyond its hard joint limit (the description's range) by more than
    :data:`POSITION_TOLERANCE`, or
  - (waltz) an arm joint was outside q_dance ± range by more than :data:`POSITION_TOLERANCE`, or
  - a servo was told to exceed its axis's velocity limit (Table II's 0.15, or the controller's
    per-axis ``velocity_limits``) by more than 1e-6;

  ``violations_by_kind`` counts them per kind (``joint_limit``, ``dance_band``, ``velocity``).
  The tolerance is on purpose: the q_dance band is a constraint of the QP (22) on the *predicted*
  position q + h·q̇ over the horizon h, computed from the previous period's measured q; the
  one-period command delay and the servos' finite stiffness under the person's load can carry a
  joint a few mrad past the edge without the controller doing anything wrong. 0.01 rad (10 % of
  the band's half width) admits that and still catches a controller that ignores the band. The
  waltz also reports ``max_dance_deviation`` (largest |q − q_dance| seen) [rad];
* ``centring`` / ``tracking``: estimated against true contact centre (link frame, error norm) and
  force (magnitude error), over samples where both say "touched" and the touch is older than
  :data:`SETTLE_TIME`;
* every scenario, ``iso15066``: the peak and sustained contact force on every body part of the
  person and on every robot link, sampled on every physics step, beside the ISO/TS 15066 limits of
  the part's region (:mod:`phri_sim.evaluation.body_forces`) and an ``ok`` flag per row and overall;
* with a sensor fault (:mod:`phri_sim.world.sensor_faults`), ``fault``: what the robot did from the
  fault time t_f on (``AfterFault.summary``, docs/phri_sim.md "Fault injection");
* ``waltz``: the person's torso path against the robot's base path (planar displacements from
  their starts): RMS error, the lag that best aligns them and the RMS error at that lag; the share
  of time the waist touches the left forearm (from the first touch on); peak / mean waist force;
* ``following`` (waltz and the followability leads): what the partner feels — drift of the
  partner's pose in the robot base frame, waist force error and band share, contact losses,
  accumulated turn, lag, travel, peak force per part and link, the bars
  (:mod:`phri_sim.evaluation.following_metrics`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from phri_common import paper
from phri_common.planar import yaw_from_quaternion
from phri_common.records import ContactState
from phri_sim.evaluation.body_forces import (
    ForceLimitTracker,
    PersonRobotForces,
    limit_report,
    part_region,
)
from phri_sim.evaluation.following_metrics import (
    BAR_SETS,
    Bars,
    FollowingSeries,
    following_summary,
)
from phri_sim.scenarios.catalogue import WALTZ_FORCE, WALTZ_LINK, Scenario
from phri_sim.world.simulation import Simulation

FloatArray = NDArray[np.float64]

POSITION_TOLERANCE = 0.01
"""Slack on position ranges for servo tracking error [rad]."""
VELOCITY_TOLERANCE = 1e-6
STANDSTILL_SPEED = 1e-3
"""A robot whose every joint rate is below this [m/s, rad/s] stands still."""
SETTLE_TIME = 0.3
"""Samples this soon after a touch begins are not scored (filter and footprint build-up) [s]."""


@dataclass
class AfterFault:
    """What the robot did from the fault time on (one sample per control period)."""

    time: float
    forces: ForceLimitTracker = field(default_factory=ForceLimitTracker)
    q_start: FloatArray | None = None
    last_base: FloatArray | None = None
    base_travel: float = 0.0
    base_displacement: float = 0.0
    max_joint_excursion: float = 0.0
    first_zero: float | None = None
    resumed: float | None = None
    stopped_since: float | None = None
    zero_periods: int = 0
    periods: int = 0
    first_command_zero: bool | None = None
    max_command: float = 0.0
    still_since: float | None = None

    def sample(self, t: float, q: FloatArray, command: FloatArray,
               qd: FloatArray | None = None) -> None:
        """Travel, excursion, command and motion state at ``t`` [s] (≥ the fault time): ``q``
        (15) [m, rad], the 15 commanded velocities, the 15 joint rates ``qd``."""
        moving = qd is not None and float(np.max(np.abs(qd))) > STANDSTILL_SPEED
        self.still_since = None if moving else (t if self.still_since is None
                                                else self.still_since)
        if self.q_start is None:
            self.q_start = q.copy()
        if self.last_base is not None:
            self.base_travel += float(np.linalg.norm(q[:2] - self.last_base))
        self.last_base = q[:2].copy()
        self.base_displacement = max(self.base_displacement,
                                     float(np.linalg.norm(q[:2] - self.q_start[:2])))
        self.max_joint_excursion = max(self.max_joint_excursion,
                                       float(np.max(np.abs(q[3:] - self.q_start[3:]))))
        self.periods += 1
        zero = not np.any(command)
        if self.first_command_zero is None:
            self.first_command_zero = zero
        self.max_command = max(self.max_command, float(np.max(np.abs(command))))
        if zero:
            self.zero_periods += 1
            self.first_zero = t if self.first_zero is None else self.first_zero
            self.stopped_since = t if self.stopped_since is None else self.stopped_since
        else:
            self.stopped_since = None
            if self.first_zero is not None and self.resumed is None:
                self.resumed = t

    def summary(self) -> dict[str, Any]:
        """JSON part (times relative to the fault time [s]; ``None`` = never)."""
        def rel(x: float | None) -> float | None:
            return None if x is None else x - self.time
        recover: float | None = 0.0
        if self.first_zero is not None:
            recover = None if self.resumed is None else self.resumed - self.first_zero
        return {
            "base_travel": self.base_travel,
            "base_displacement": self.base_displacement,
            "max_joint_excursion": self.max_joint_excursion,
            "time_to_zero_command": rel(self.first_zero),
            "time_to_stop": rel(self.stopped_since),
            "time_to_standstill": rel(self.still_since),
            "time_to_recover": recover,
            "zero_command_periods": self.zero_periods,
            "periods": self.periods,
            "command_zero_at_fault": self.first_command_zero,
            "max_command": self.max_command,
        }


@dataclass
class _LinkSeries:
    touched: list[bool] = field(default_factory=list)
    normal_force: list[float] = field(default_factory=list)
    center_error: list[float] = field(default_factory=list)
    force_error: list[float] = field(default_factory=list)
    touch_start: float = -math.inf


class MetricsRecorder:
    """Collects one sample per control period (module docstring)."""

    def __init__(self, kind: str, velocity_limit: float | FloatArray = paper.VELOCITY_LIMIT,
                 position_ranges: FloatArray | None = None,
                 fault_time: float | None = None, desired_force: float = WALTZ_FORCE,
                 bars: Bars | None = None) -> None:
        self.kind = kind
        self.desired_force = desired_force
        self.bars = bars or Bars()
        self.velocity_limit = velocity_limit
        self.position_ranges = position_ranges
        self.times: list[float] = []
        self.links: dict[str, _LinkSeries] = {}
        self.base_path: list[FloatArray] = []
        self.torso_path: list[FloatArray] = []
        self.base_pose: list[FloatArray] = []
        self.partner_pose: list[FloatArray] = []
        self.waist_force: list[float] = []
        self.base_twist: list[FloatArray] = []
        self.arm_velocity: list[FloatArray] = []
        self.commands: list[FloatArray] = []
        self.violations = 0
        self.violation_kinds: dict[str, int] = {"joint_limit": 0, "dance_band": 0, "velocity": 0}
        self.max_command = 0.0
        self.max_band_deviation = 0.0
        self.forces = ForceLimitTracker()
        self.touching: set[tuple[str, str]] = set()
        self.after = None if fault_time is None else AfterFault(fault_time)
        self.fault_changes: tuple[float | None, int] = (None, 0)
        """(sim time [s] of the first sensor message the fault changed, how many it changed)."""
        self._reader: PersonRobotForces | None = None
        self._sim: Simulation | None = None

    def watch(self, sim: Simulation) -> None:
        """Read the person↔robot contact forces of ``sim`` after every physics step (it sets
        ``sim.on_step``)."""
        self._sim = sim
        self._reader = PersonRobotForces(sim.model, sim.person.geom_part)
        sim.on_step = self._on_step

    def _on_step(self) -> None:
        assert self._reader is not None and self._sim is not None
        reader = self._reader
        parts, links, pairs = reader.read(self._sim.data)
        forces = {**parts, **links}
        t = self._sim.time
        self.forces.add(t, forces, (*reader.parts, *reader.links))
        self.touching |= pairs
        if self.after is not None and t >= self.after.time - 1e-9:
            self.after.forces.add(t, forces, (*reader.parts, *reader.links))

    def sample(self, sim: Simulation, command: FloatArray,
               estimates: Mapping[str, ContactState]) -> None:
        """Record the current state; ``command`` = the 15 velocities sent (before clipping)."""
        t = sim.time
        self.times.append(t)
        q = sim.q
        bad_joint = _outside(q, sim.robot.position_limits, POSITION_TOLERANCE)
        bad_band = False
        if self.position_ranges is not None:
            bad_band = _outside(q, self.position_ranges, POSITION_TOLERANCE)
            finite = np.isfinite(self.position_ranges).all(axis=1)
            centre = self.position_ranges[finite].mean(axis=1)
            self.max_band_deviation = max(self.max_band_deviation,
                                          float(np.max(np.abs(q[finite] - centre))))
        peak = float(np.max(np.abs(command))) if command.size else 0.0
        self.max_command = max(self.max_command, peak)
        bad_vel = bool(np.any(np.abs(command) > self.velocity_limit + VELOCITY_TOLERANCE))
        if bad_joint or bad_band or bad_vel:
            self.violations += 1
            self.violation_kinds["joint_limit"] += int(bad_joint)
            self.violation_kinds["dance_band"] += int(bad_band)
            self.violation_kinds["velocity"] += int(bad_vel)
        truth = sim.ground_truth()
        for link, gt in truth.items():
            series = self.links.setdefault(link, _LinkSeries())
            touched = gt.in_contact and gt.normal_force > 0.0
            if touched and not (series.touched and series.touched[-1]):
                series.touch_start = t
            series.touched.append(touched)
            series.normal_force.append(gt.normal_force)
            est = estimates.get(link)
            if touched and est is not None and est.in_contact and (
                t - series.touch_start >= SETTLE_TIME
            ):
                series.center_error.append(float(np.linalg.norm(est.center - gt.center_link)))
                series.force_error.append(
                    abs(float(np.linalg.norm(est.force)) - float(np.linalg.norm(gt.force_link)))
                )
        if self.after is not None and t >= self.after.time - 1e-9:
            self.after.sample(t, q, command, sim.qd)
        self.base_path.append(q[:2].copy())
        torso = next((p.name for p in sim.parts if p.name == "person_torso"), None)
        if torso is not None:
            self.torso_path.append(sim.part_pose(torso)[0][:2])
        lead = truth.get(WALTZ_LINK)  # as sim/contacts/<link>/wrench: ‖f‖
        self.waist_force.append(0.0 if lead is None else float(np.linalg.norm(lead.force_link)))
        self.base_pose.append(q[:3].copy())
        self.base_twist.append(sim.base_twist())
        self.arm_velocity.append(sim.qd[3:].copy())
        self.commands.append(np.array(command, dtype=np.float64))
        if sim.parts:  # the partner's pose: the first part (torso / pelvis), as sim/person/poses
            pos, quat = sim.part_pose(sim.parts[0].name)
            self.partner_pose.append(np.array([pos[0], pos[1], yaw_from_quaternion(*quat)]))

    # -- reduction ------------------------------------------------------------------------------
    def _link_summary(self, series: _LinkSeries) -> dict[str, Any]:
        touched = np.array(series.touched, dtype=bool)
        force = np.array(series.normal_force)
        out: dict[str, Any] = {
            "touched_share": float(touched.mean()) if touched.size else 0.0,
            "peak_force": float(force.max()) if force.size else 0.0,
            "mean_force_touched": float(force[touched].mean()) if touched.any() else 0.0,
        }
        if self.kind in ("centring", "tracking"):
            ce, fe = np.array(series.center_error), np.array(series.force_error)
            out["scored_samples"] = int(ce.size)
            if ce.size:
                out["center_error_mean"] = float(ce.mean())
                out["center_error_max"] = float(ce.max())
                out["force_error_mean"] = float(fe.mean())
                out["force_error_max"] = float(fe.max())
        return out

    def summary(self) -> dict[str, Any]:
        """The metrics as a JSON-ready dict."""
        out: dict[str, Any] = {
            "samples": len(self.times),
            "sim_time": self.times[-1] if self.times else 0.0,
            "limit_violations": self.violations,
            "violations_by_kind": dict(self.violation_kinds),
            "max_command": self.max_command,
            "links": {link: self._link_summary(s) for link, s in self.links.items()},
        }
        if self._reader is not None:
            out["iso15066"] = self._iso_summary(self.forces)
        if self.after is not None:
            after = self.after.summary()
            if self._reader is not None:
                after["forces"] = self._iso_summary(self.after.forces)
            after["fault_time"] = self.after.time
            after["first_changed_at"], after["messages_changed"] = self.fault_changes
            out["fault"] = after
        if self.kind == "waltz":
            out["waltz"] = self._waltz_summary()
            series = self.following_series()
            if series is not None:
                out["following"] = following_summary(series, self.desired_force, self.bars,
                                                     self._peak_forces())
        return out

    def following_series(self) -> FollowingSeries | None:
        """The recorded inputs of the ``following`` block (``None`` without a partner or
        samples)."""
        if WALTZ_LINK not in self.links or len(self.partner_pose) != len(self.times) or (
                not self.times):
            return None
        force = np.array(self.waist_force)
        commands = np.array(self.commands)
        return FollowingSeries(np.array(self.times), np.array(self.base_pose),
                               np.array(self.partner_pose), force, force > 0.0,
                               twist=np.array(self.base_twist), command=commands[:, :3],
                               arm_velocity=np.array(self.arm_velocity),
                               arm_command=commands[:, 3:])

    def _peak_forces(self) -> dict[str, dict[str, float]] | None:
        """Peak contact force per partner body part and per robot link [N] (every physics
        step, :mod:`phri_sim.evaluation.body_forces`)."""
        if self._reader is None:
            return None
        return {"person": {p: self.forces.peak(p) for p in self._reader.parts},
                "robot": {lk: self.forces.peak(lk) for lk in self._reader.links}}

    def _iso_summary(self, tracker: ForceLimitTracker) -> dict[str, Any]:
        """Per person body part and per robot link: peak and sustained force [N] beside the
        ISO/TS 15066 limits (:func:`~phri_sim.evaluation.body_forces.limit_report`). A part is held
        to its own region; a link to the strictest region among the parts it touched during the run
        (no touch: no region, ok)."""
        assert self._reader is not None
        person = {p: limit_report(part_region(p), tracker.peak(p), tracker.sustained(p))
                  for p in self._reader.parts}
        links: dict[str, Any] = {}
        for link in self._reader.links:
            touched = sorted({p for p, lk in self.touching if lk == link})
            region = min((part_region(p) for p in touched),
                         key=lambda r: (r.quasi_static, r.transient), default=None)
            row = limit_report(region, tracker.peak(link), tracker.sustained(link))
            row["touched_parts"] = touched
            links[link] = row
        ok = all(r["ok"] for r in (*person.values(), *links.values()))
        return {"person": person, "robot_links": links, "ok": ok}

    def _waltz_summary(self) -> dict[str, Any]:
        series = self.links.get(WALTZ_LINK, _LinkSeries())
        touched = np.array(series.touched, dtype=bool)
        first = int(np.argmax(touched)) if touched.any() else len(touched)
        held = touched[first:]
        force = np.array(series.normal_force)[first:]
        base = np.array(self.base_path)
        torso = np.array(self.torso_path)
        result: dict[str, Any] = {
            "max_dance_deviation": self.max_band_deviation,
            "contact_held_share": float(held.mean()) if held.size else 0.0,
            "peak_force": float(force.max()) if force.size else 0.0,
            "mean_force": float(force[held].mean()) if held.any() else 0.0,
        }
        if base.shape[0] >= 2 and torso.shape == base.shape:
            b = base - base[0]
            p = torso - torso[0]
            rms, lag, rms_lag = path_errors(np.array(self.times), p, b)
            result.update({
                "path_rms_error": rms,
                "path_lag": lag,
                "path_rms_error_at_lag": rms_lag,
                "torso_travel": float(np.sum(np.linalg.norm(np.diff(p, axis=0), axis=1))),
                "base_travel": float(np.sum(np.linalg.norm(np.diff(b, axis=0), axis=1))),
            })
        return result


def _outside(q: FloatArray, ranges: FloatArray, tolerance: float) -> bool:
    """Whether any q is below ``ranges[:, 0]`` or above ``ranges[:, 1]`` by more than
    ``tolerance`` (infinite bounds never bind)."""
    return bool(np.any(q < ranges[:, 0] - tolerance) or np.any(q > ranges[:, 1] + tolerance))


def path_errors(times: FloatArray, leader: FloatArray, follower: FloatArray,
                max_lag: float = 5.0) -> tuple[float, float, float]:
    """(RMS ‖leader − follower‖ [m], lag [s] minimising the RMS of leader(t) − follower(t + lag),
    that minimum RMS [m]) for equally sampled planar paths."""
    err = np.linalg.norm(leader - follower, axis=1)
    rms = float(np.sqrt(np.mean(err**2)))
    if times.size < 2:
        return rms, 0.0, rms
    dt = float(times[1] - times[0])
    best_lag, best = 0.0, rms
    for k in range(1, int(max_lag / dt) + 1):
        if k >= leader.shape[0] - 1:
            break
        e = np.linalg.norm(leader[:-k] - follower[k:], axis=1)
        r = float(np.sqrt(np.mean(e**2)))
        if r < best:
            best, best_lag = r, k * dt
    return rms, best_lag, best


def _dance_ranges(params: Mapping[str, Any]) -> FloatArray | None:
    """(15, 2) joint bands q_dance ± q_dance_range [rad] for the arms (base unbounded) when the
    controller's ``q_dance_enabled``; else ``None``."""
    if not params.get("q_dance_enabled"):
        return None
    q = np.array(params["q_dance"], dtype=np.float64)
    r = float(params["q_dance_range"])
    ranges = np.full((15, 2), [-np.inf, np.inf])
    ranges[3:, 0], ranges[3:, 1] = q - r, q + r
    return ranges


def scenario_metrics(scenario: Scenario, sim: Simulation,
                     fault_time: float | None) -> MetricsRecorder:
    """The metrics recorder of a run of ``scenario`` on ``sim`` (the controller parameters' velocity
    limits, dance band and desired waist force), watching its every physics step; the ``fault``
    block from ``fault_time`` [s] (``None``: no such block)."""
    params = scenario.controller_parameters
    desired = params.get(f"{WALTZ_LINK}.desired_force")
    limit = float(params.get("velocity_limit", paper.VELOCITY_LIMIT))
    per_axis = params.get("velocity_limits")
    metrics = MetricsRecorder(
        scenario.metrics,
        limit if per_axis is None else np.minimum(np.asarray(per_axis, dtype=float), limit),
        _dance_ranges(params), fault_time=fault_time,
        desired_force=WALTZ_FORCE if desired is None else float(np.linalg.norm(desired)),
        bars=BAR_SETS[scenario.bars],
    )
    metrics.watch(sim)
    return metrics
