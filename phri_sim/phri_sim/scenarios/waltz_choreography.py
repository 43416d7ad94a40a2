"""Waltz choreography in 3/4 time: the partner's torso path and heading over time (pure).

A figure is a list of beats; each beat is one step of the torso, given in the partner's own frame
at that beat (``forward`` along the facing direction, ``left`` to the partner's left) [m], with
the heading change over the beat ``turn`` [rad] (positive = to the left, counter-clockwise seen
from above). Three beats make a bar. The figures (slow waltz, simplified to the torso):

* closed change forward: forward, side, close (feet together: the torso stays);
* closed change backward: back, side, close;
* natural turn (a right turn, two bars): forward, side, close, back, side, close, turning
  clockwise evenly over the six beats;
* reverse turn (a left turn, two bars): the same turning counter-clockwise.

:data:`ROUTINE` dances closed change forward, two natural turns (360° clockwise), closed change
backward, two reverse turns (360° counter-clockwise), closed change forward: ten bars.

Keyframes. At the end of beat k the torso stands at ``p_k = p_{k−1} + R(ψ_{k−1} + ½Δψ_k)
[forward, left]`` (world displacement of the step, heading taken at mid-beat) with heading
``ψ_k = ψ_{k−1} + Δψ_k``. Between keyframes x, y and ψ are interpolated each with a
shape-preserving piecewise cubic (PCHIP, Fritsch–Carlson): C¹, no overshoot, zero velocity where
the torso stops (a close), a nearly constant turn rate inside a turn — a torso that flows through
the steps as a dancer's does, instead of stopping on every beat.

Tempos (:data:`TEMPOS`):

* ``paper``: within Table II's 0.15 m/s and 0.15 rad/s with margin for the robot to catch up
  (beat 5.5 s, steps 0.20 m, sides 0.15 m, 90° per bar: peak 0.055 m/s, 0.13 rad/s);
* ``tempo``: a real slow waltz (bar 2 s, steps 0.30 m, sides 0.25 m, 90° per bar).

Frame: the path starts at the origin with heading 0 (the partner's start frame); the scenario
places and turns it in the world.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.interpolate import PchipInterpolator

FloatArray = NDArray[np.float64]

BEATS_PER_BAR = 3
"""3/4 time."""


@dataclass(frozen=True)
class Beat:
    """One step: displacement in the partner's frame [m] and heading change [rad]."""

    forward: float
    left: float
    turn: float = 0.0


@dataclass(frozen=True)
class Tempo:
    """How fast and how large the figures are danced.

    Attributes:
        name: tempo name.
        beat: duration of one beat [s] (a bar is three).
        step: length of a forward or backward step [m].
        side: length of a side step [m].
        turn_per_bar: heading change per bar in the turns [rad].
    """

    name: str
    beat: float
    step: float
    side: float
    turn_per_bar: float

    def __post_init__(self) -> None:
        for field_name in ("beat", "step", "side", "turn_per_bar"):
            value = getattr(self, field_name)
            if not (math.isfinite(value) and value > 0.0):
                raise ValueError(f"tempo {self.name!r}: {field_name} = {value} must be a finite "
                                 "number > 0")


TEMPOS: dict[str, Tempo] = {
    "paper": Tempo("paper", beat=5.5, step=0.20, side=0.15, turn_per_bar=0.5 * math.pi),
    "tempo": Tempo("tempo", beat=2.0 / 3.0, step=0.30, side=0.25, turn_per_bar=0.5 * math.pi),
}
"""The two tempos (module docstring)."""


def closed_change(tempo: Tempo, direction: float) -> list[Beat]:
    """One bar: a step (``direction`` +1 forward, −1 back), a side step (to the left going
    forward, to the right going back), close."""
    return [Beat(direction * tempo.step, 0.0), Beat(0.0, direction * tempo.side), Beat(0.0, 0.0)]


def turn_figure(tempo: Tempo, direction: float) -> list[Beat]:
    """Two bars turning ``direction`` (−1 natural = clockwise, +1 reverse = counter-clockwise)
    by ``2 · turn_per_bar``: forward, side, close, back, side, close, the turn spread evenly."""
    d = direction * tempo.turn_per_bar / BEATS_PER_BAR
    side = -direction * tempo.side  # the side step opens away from the turn's centre
    return [Beat(tempo.step, 0.0, d), Beat(0.0, side, d), Beat(0.0, 0.0, d),
            Beat(-tempo.step, 0.0, d), Beat(0.0, -side, d), Beat(0.0, 0.0, d)]


def routine(tempo: Tempo) -> list[Beat]:
    """:data:`ROUTINE` (module docstring) at ``tempo``: closed change forward, two natural
    turns, closed change backward, two reverse turns, closed change forward."""
    return [*closed_change(tempo, 1.0), *turn_figure(tempo, -1.0), *turn_figure(tempo, -1.0),
            *closed_change(tempo, -1.0), *turn_figure(tempo, 1.0), *turn_figure(tempo, 1.0),
            *closed_change(tempo, 1.0)]


ROUTINE = "closed change fwd, 2 natural turns, closed change back, 2 reverse turns, closed change"


def keyframes(beats: Sequence[Beat]) -> tuple[FloatArray, FloatArray]:
    """Keyframes after each beat (module docstring): positions (n+1, 2) [m] and headings (n+1,)
    [rad], the first at the origin with heading 0."""
    points = [np.zeros(2)]
    headings = [0.0]
    for beat in beats:
        psi = headings[-1] + 0.5 * beat.turn
        c, s = math.cos(psi), math.sin(psi)
        step = np.array([c * beat.forward - s * beat.left, s * beat.forward + c * beat.left])
        points.append(points[-1] + step)
        headings.append(headings[-1] + beat.turn)
    return np.array(points), np.array(headings)


class Choreography:
    """The torso's planar pose over time: intro (standing in the hold), the beats, outro.

    Args:
        beats: the steps.
        beat_time: duration of each beat [s].
        intro: standing still before the first beat [s].
        outro: standing still after the last beat [s].
    """

    def __init__(self, beats: Sequence[Beat], beat_time: float, intro: float = 0.0,
                 outro: float = 0.0) -> None:
        if not beats:
            raise ValueError("choreography: beats must not be empty")
        if not (beat_time > 0.0 and intro >= 0.0 and outro >= 0.0):
            raise ValueError(f"choreography: beat_time = {beat_time} must be > 0, intro = "
                             f"{intro} and outro = {outro} ≥ 0")
        points, headings = keyframes(beats)
        self.times = intro + beat_time * np.arange(len(beats) + 1)
        self.points, self.headings = points, headings
        self.duration = float(self.times[-1] + outro)
        self._x = PchipInterpolator(self.times, points[:, 0])
        self._y = PchipInterpolator(self.times, points[:, 1])
        self._psi = PchipInterpolator(self.times, headings)

    def pose(self, t: float) -> tuple[FloatArray, float, FloatArray, float]:
        """(position (2) [m], heading [rad], velocity (2) [m/s], turn rate [rad/s]) at ``t``
        [s]; held at the ends."""
        tc = min(max(t, float(self.times[0])), float(self.times[-1]))
        moving = self.times[0] < t < self.times[-1]
        p = np.array([float(self._x(tc)), float(self._y(tc))])
        v = np.array([float(self._x(tc, 1)), float(self._y(tc, 1))]) if moving else np.zeros(2)
        rate = float(self._psi(tc, 1)) if moving else 0.0
        return p, float(self._psi(tc)), v, rate

    def sample(self, dt: float) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
        """(times, positions (n, 2), headings, planar speeds) every ``dt`` [s] over the whole
        duration (for checks and plots)."""
        ts = np.arange(0.0, self.duration + 0.5 * dt, dt)
        poses = [self.pose(float(t)) for t in ts]
        return (ts, np.array([p[0] for p in poses]), np.array([p[1] for p in poses]),
                np.array([np.linalg.norm(p[2]) for p in poses]))


def waltz_choreography(tempo: str | Tempo, intro: float = 2.0, outro: float = 3.0
                       ) -> Choreography:
    """:func:`routine` at a tempo of :data:`TEMPOS` (by name) or a given :class:`Tempo`.

    Raises:
        ValueError: unknown tempo name (the message lists the known ones).
    """
    if isinstance(tempo, str):
        if tempo not in TEMPOS:
            raise ValueError(f"waltz tempo {tempo!r} unknown; allowed: {', '.join(TEMPOS)}")
        tempo = TEMPOS[tempo]
    return Choreography(routine(tempo), tempo.beat, intro, outro)
