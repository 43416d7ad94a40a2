"""A visual human figure around the recorded person poses (pure: numpy only, no rendering).

The simulated partner is a few rigid bodies (torso with waist and chest, two hands). For the
video a figure is built around them, kinematically, from ``sim/person/poses`` alone:

* **Upper body** in the torso's heading frame (forward = the way the partner faces, left, up):
  shoulders, neck and head above the torso pose, hips below it.
* **Arms**: two-link inverse kinematics (:func:`two_link_ik`) from each shoulder to the recorded
  hand, the elbow bent down and out. A hand farther than the arm can reach plus
  :data:`REACH_MARGIN` (a parked, unused hand) is drawn in the dance hold instead
  (:data:`HOLD_LEFT`, :data:`HOLD_RIGHT`).
* **Legs**: feet planted on the floor; a foot steps when the hips move or turn away from it
  (:class:`Feet`), one foot at a time, with the knee bent forward by the same IK.

Lengths are an adult's (about 1.75 m tall with the torso pose at the waist, 1.0 m up); they are
visual only: nothing here touches the physics.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]

UP = np.array([0.0, 0.0, 1.0])


@dataclass(frozen=True)
class FigureDims:
    """Segment lengths and offsets of the figure [m] (offsets in the torso heading frame:
    forward, left, up from the torso pose)."""

    upper_arm: float = 0.30
    forearm: float = 0.28
    thigh: float = 0.43
    shin: float = 0.43
    shoulder_up: float = 0.52
    shoulder_half_width: float = 0.19
    neck: float = 0.17
    head_radius: float = 0.11
    hip_down: float = 0.10
    hip_half_width: float = 0.10
    ankle_height: float = 0.08
    foot_length: float = 0.24


DIMS = FigureDims()
REACH_MARGIN = 0.15
"""A recorded hand farther than upper arm + forearm + this from its shoulder is not in use (the
scenario parked it) and the arm is drawn in the hold pose instead [m]."""
HOLD_LEFT = (0.36, 0.08, -0.18)
"""Hold position of the left hand relative to the left shoulder (forward, left, up) [m]:
reaching forward towards the partner's shoulder."""
HOLD_RIGHT = (0.26, -0.08, -0.36)
"""Hold position of the right hand relative to the right shoulder [m]: forward and down, resting
on the partner's arm at the waist."""


def heading_frame(yaw: float) -> FloatArray:
    """3×3 matrix whose columns are forward, left, up of a figure facing ``yaw`` [rad]."""
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def two_link_ik(root: FloatArray, target: FloatArray, l1: float, l2: float,
                pole: FloatArray) -> tuple[FloatArray, FloatArray]:
    """(middle joint, end) of a two-link chain of lengths ``l1``, ``l2`` [m] from ``root``
    towards ``target``, bent towards ``pole`` (a direction).

    Law of cosines: with d = |target − root| clamped to [|l1 − l2|, l1 + l2], the middle joint
    lies a = (l1² − l2² + d²) / (2d) along the chain axis u and h = √(l1² − a²) along the part
    of ``pole`` orthogonal to u. The end reaches ``target`` whenever d is in range; otherwise it
    lies on the line root → target at the clamped distance (straight or folded chain). Both
    links keep their lengths in every case.
    """
    axis = np.asarray(target, dtype=float) - root
    dist = float(np.linalg.norm(axis))
    u = axis / dist if dist > 1e-9 else -UP
    d = min(max(dist, abs(l1 - l2) + 1e-9), l1 + l2)
    a = (l1 * l1 - l2 * l2 + d * d) / (2.0 * d)
    h = math.sqrt(max(l1 * l1 - a * a, 0.0))
    w = np.asarray(pole, dtype=float) - np.dot(pole, u) * u
    if np.linalg.norm(w) < 1e-9:  # pole along the chain: bend any orthogonal way
        w = np.cross(u, UP if abs(u[2]) < 0.9 else np.array([1.0, 0.0, 0.0]))
    w = w / np.linalg.norm(w)
    return root + a * u + h * w, root + d * u


@dataclass
class _Foot:
    planted: FloatArray
    yaw: float
    swing_from: FloatArray | None = None
    swing_yaw_from: float = 0.0
    swing_start: float = 0.0


@dataclass
class Feet:
    """Kinematic stepping: each foot stays planted until the hips move or turn away from it.

    A foot's home is under its hip (``hip_half_width`` to the side of the torso position, the
    figure's heading). When no foot is in the air and the larger of the two errors
    ``|home − planted| + turn_weight·|Δyaw|`` exceeds ``step_distance`` [m], that foot lifts and
    swings to its home (predicted ``swing_time`` ahead from the hip velocity) in ``swing_time``
    [s] on a smooth-step path with ``lift`` [m] of clearance. At most one step starts per
    ``beat`` [s]: three steps to a 3/4 bar of 3·beat.
    """

    dims: FigureDims = DIMS
    step_distance: float = 0.07
    turn_weight: float = 0.25
    swing_time: float = 0.35
    beat: float = 0.5
    lift: float = 0.06
    feet: list[_Foot] = field(default_factory=list)
    steps: int = 0
    _last: tuple[float, FloatArray] | None = None
    _last_step: float = -math.inf

    def _home(self, hip_xy: FloatArray, yaw: float, side: int) -> FloatArray:
        left = np.array([-math.sin(yaw), math.cos(yaw)])
        return np.asarray(hip_xy, dtype=float) + side * self.dims.hip_half_width * left

    def update(self, t: float, hip_xy: FloatArray, yaw: float) -> list[tuple[FloatArray, float]]:
        """Advance to time ``t`` [s] with the hips at ``hip_xy`` [m] facing ``yaw`` [rad];
        return (ankle position [m], foot yaw [rad]) of the left then the right foot."""
        hip_xy = np.asarray(hip_xy, dtype=float)
        if not self.feet:
            self.feet = [_Foot(self._home(hip_xy, yaw, s), yaw) for s in (1, -1)]
        vel = np.zeros(2)
        if self._last is not None and t > self._last[0]:
            vel = (hip_xy - self._last[1]) / (t - self._last[0])
        self._last = (t, hip_xy)
        for foot in self.feet:  # land feet whose swing is over
            if foot.swing_from is not None and t >= foot.swing_start + self.swing_time:
                foot.swing_from = None
        if all(f.swing_from is None for f in self.feet) and t - self._last_step >= self.beat:
            self._maybe_step(t, hip_xy, vel, yaw)
        return [self._pose(foot, t) for foot in self.feet]

    def _maybe_step(self, t: float, hip_xy: FloatArray, vel: FloatArray, yaw: float) -> None:
        errors = [float(np.linalg.norm(self._home(hip_xy, yaw, s) - f.planted))
                  + self.turn_weight * abs(_wrap(yaw - f.yaw)) for s, f in zip((1, -1), self.feet,
                                                                            strict=True)]
        i = int(np.argmax(errors))
        if errors[i] <= self.step_distance:
            return
        foot, side = self.feet[i], (1, -1)[i]
        ahead = hip_xy + vel * self.swing_time
        foot.swing_from, foot.swing_yaw_from = foot.planted, foot.yaw
        foot.planted, foot.yaw = self._home(ahead, yaw, side), yaw
        foot.swing_start = t
        self._last_step = t
        self.steps += 1

    def _pose(self, foot: _Foot, t: float) -> tuple[FloatArray, float]:
        h = self.dims.ankle_height
        if foot.swing_from is None:
            return np.array([*foot.planted, h]), foot.yaw
        s = min(max((t - foot.swing_start) / self.swing_time, 0.0), 1.0)
        k = s * s * (3.0 - 2.0 * s)
        xy = foot.swing_from + k * (foot.planted - foot.swing_from)
        yaw = foot.swing_yaw_from + k * _wrap(foot.yaw - foot.swing_yaw_from)
        return np.array([*xy, h + self.lift * math.sin(math.pi * s)]), yaw


def _wrap(angle: float) -> float:
    """``angle`` wrapped into [−π, π) [rad]."""
    return (angle + math.pi) % (2.0 * math.pi) - math.pi


@dataclass(frozen=True)
class Skeleton:
    """Joint positions of the figure (world frame) [m]."""

    joints: dict[str, FloatArray]
    foot_yaw: tuple[float, float]


def _arm(shoulder: FloatArray, hand: FloatArray | None, hold: tuple[float, float, float],
         frame: FloatArray, side: int, dims: FigureDims) -> tuple[FloatArray, FloatArray]:
    """(elbow, wrist) of one arm: IK to ``hand``, or to the hold pose when it is out of reach."""
    reach = dims.upper_arm + dims.forearm
    if hand is None or np.linalg.norm(hand - shoulder) > reach + REACH_MARGIN:
        hand = shoulder + frame @ np.array(hold)
    pole = frame @ np.array([0.0, 0.6 * side, -1.0])  # elbow down and out
    return two_link_ik(shoulder, hand, dims.upper_arm, dims.forearm, pole)


def skeleton(torso: FloatArray, yaw: float, hands: tuple[FloatArray | None, FloatArray | None],
             feet: list[tuple[FloatArray, float]], dims: FigureDims = DIMS) -> Skeleton:
    """The figure's joints for a torso at ``torso`` [m] facing ``yaw`` [rad], the recorded
    (left, right) hand positions [m] (``None`` = not recorded) and the feet of :class:`Feet`."""
    frame = heading_frame(yaw)
    fwd, left = frame[:, 0], frame[:, 1]
    top = torso + dims.shoulder_up * UP
    hip = torso - dims.hip_down * UP
    j: dict[str, FloatArray] = {"neck": top, "head": top + (dims.neck + dims.head_radius) * UP,
                                "pelvis": hip}
    j["nose"] = j["head"] + 0.95 * dims.head_radius * fwd
    j["hair"] = j["head"] + dims.head_radius * (0.25 * UP - 0.2 * fwd)
    for name, side, hold, hand in (("left", 1, HOLD_LEFT, hands[0]),
                                   ("right", -1, HOLD_RIGHT, hands[1])):
        shoulder = top + side * dims.shoulder_half_width * left
        j[f"{name}_shoulder"] = shoulder
        j[f"{name}_elbow"], j[f"{name}_wrist"] = _arm(shoulder, hand, hold, frame, side, dims)
    for name, side, (ankle, foot_yaw) in (("left", 1, feet[0]), ("right", -1, feet[1])):
        hip_joint = hip + side * dims.hip_half_width * left
        j[f"{name}_hip"] = hip_joint
        j[f"{name}_knee"], j[f"{name}_ankle"] = two_link_ik(hip_joint, ankle, dims.thigh,
                                                           dims.shin, fwd)
        toe_dir = heading_frame(foot_yaw)[:, 0]
        j[f"{name}_toe"] = j[f"{name}_ankle"] + dims.foot_length * 0.75 * toe_dir
        j[f"{name}_toe"][2] = 0.03
        j[f"{name}_heel"] = j[f"{name}_ankle"] - dims.foot_length * 0.25 * toe_dir
        j[f"{name}_heel"][2] = 0.03
    return Skeleton(j, (feet[0][1], feet[1][1]))


BONES: tuple[tuple[str, str, float], ...] = (
    ("neck", "pelvis", 0.0),  # spine (hidden inside the torso geoms; drawn thin)
    ("left_shoulder", "right_shoulder", 0.055),
    *((f"{s}_{a}", f"{s}_{b}", r) for s in ("left", "right") for a, b, r in (
        ("shoulder", "elbow", 0.045), ("elbow", "wrist", 0.038), ("hip", "knee", 0.065),
        ("knee", "ankle", 0.05), ("heel", "toe", 0.045))),
    ("left_hip", "right_hip", 0.08),
)
"""Capsules drawn between joints: (joint a, joint b, radius [m]); radius 0 = a neck capsule of
head-sized width is drawn instead (see :func:`bones`)."""


def bones(sk: Skeleton, dims: FigureDims = DIMS) -> list[tuple[FloatArray, FloatArray, float]]:
    """(start, end, radius [m]) of every capsule of the figure, the neck included."""
    j = sk.joints
    out = [(j[a], j[b], r) for a, b, r in BONES if r > 0.0]
    out.append((j["neck"] - 0.05 * UP, j["head"] - dims.head_radius * UP, 0.05))
    return out
