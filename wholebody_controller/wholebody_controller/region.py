"""The desired contact region Ω_d of one link and its track force (10)–(11) (pure).

Paper (V-B, Algorithm 1 line 14): Ω_d ← Ω_i at the onset of a touch (plus the 0.01 m margin of
VI-A.2), and μ = f_R(x⁺ − x_d⁺) − f_R(x_d⁻ − x⁻) per axis. Ω_i is the box of the contacting
taxels, so it moves in steps of one taxel pitch; two documented deviations (both off by default,
docs/wholebody_controller.md "Desired region") keep a still hand from producing a track force:

* ``region_window`` w [s]: Ω_d grows to the union of (Ω_i + margin) over the first w seconds of
  the touch ("derived from past contact regions", V-B). At onset only the first taxels are over
  the threshold; the footprint grows while the press builds up (and a second hand of a two-sided
  press lands a few periods after the first), so an Ω_d locked on the first frame is smaller than
  the touch and yields a track force with nothing sliding.
* ``region_hysteresis`` h [m]: each face of Ω_i engages the track force only once it is more
  than h past its face of Ω_d, and disengages when it is back inside (a Schmitt trigger per
  face). While engaged, (11) applies unchanged. A boundary taxel flickering over the threshold
  moves a face by one pitch (7.5 mm); with h ≥ one pitch that flicker no longer toggles the track
  force (237 toggles of 0 ↔ 1 N in 6 s with a still hand at h = 0).

This module holds the formulas; Ω_d itself is part of a link's task state and is locked, grown
and reset by the task step (:func:`~wholebody_controller.task_step.region_update`).
"""

from __future__ import annotations

from collections.abc import MutableSequence

from phri_common.jit import jitable
from wholebody_controller.so3 import Vec3

Box = tuple[Vec3, Vec3]


@jitable
def track_force(region_min: Vec3, region_max: Vec3, desired_min: Vec3,
                desired_max: Vec3) -> Vec3:
    """μ (10)–(11) [m]: f_R(x⁺ − x_d⁺) − f_R(x_d⁻ − x⁻) per axis, f_R(x) = max(x, 0).

    Zero while Ω_i ⊆ Ω_d; a region extending past the desired +x face gives +x (the link is pushed
    the way the contact slid, so the contact returns into Ω_d), past the −x face gives −x. Same
    frame as the inputs (here the link frame).
    """
    ux, uy, uz = (region_max[0] - desired_max[0], region_max[1] - desired_max[1],
                  region_max[2] - desired_max[2])
    lx, ly, lz = (desired_min[0] - region_min[0], desired_min[1] - region_min[1],
                  desired_min[2] - region_min[2])
    # f_R written as conditionals: builtin max() costs a call each, six times per step.
    return ((ux if ux > 0.0 else 0.0) - (lx if lx > 0.0 else 0.0),
            (uy if uy > 0.0 else 0.0) - (ly if ly > 0.0 else 0.0),
            (uz if uz > 0.0 else 0.0) - (lz if lz > 0.0 else 0.0))


@jitable
def grow_box(box: Box, lo: Vec3, hi: Vec3, margin: float) -> Box:
    """The smallest box holding ``box`` and [lo − margin, hi + margin] [m]."""
    (a, b, c), (d, e, f) = box
    return ((min(a, lo[0] - margin), min(b, lo[1] - margin), min(c, lo[2] - margin)),
            (max(d, hi[0] + margin), max(e, hi[1] + margin), max(f, hi[2] + margin)))


@jitable
def gated_track_force(lo: Vec3, hi: Vec3, desired_min: Vec3, desired_max: Vec3, h: float,
                      engaged: MutableSequence[bool]) -> Vec3:
    """μ (11) [m] of Ω_i = [lo, hi] against Ω_d, each face gated by the hysteresis ``h`` [m]
    (module docstring); ``engaged`` (6: +x, −x, +y, −y, +z, −z) is the faces' trigger state,
    updated in place. Straight-line code, so the compiled step can use it too."""
    mu = [0.0, 0.0, 0.0]
    for k in range(3):
        up, down = hi[k] - desired_max[k], desired_min[k] - lo[k]  # past the + and − face
        if up <= 0.0:
            engaged[2 * k] = False
        elif up > h:
            engaged[2 * k] = True
        if down <= 0.0:
            engaged[2 * k + 1] = False
        elif down > h:
            engaged[2 * k + 1] = True
        if engaged[2 * k]:
            mu[k] += up
        if engaged[2 * k + 1]:
            mu[k] -= down
    return (mu[0], mu[1], mu[2])
