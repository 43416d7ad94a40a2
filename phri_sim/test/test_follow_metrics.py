"""The partner's pose in the robot frame (phri_sim.metrics.relative_drift): a couple turning
together has no drift, a robot standing still while the partner turns has all of it."""

from __future__ import annotations

import math

import numpy as np
import pytest

from phri_sim.metrics import relative_drift


def _circle(n: int = 200) -> tuple[np.ndarray, ...]:
    """A couple turning 270° counter-clockwise about the origin: base at radius 0.7 facing the
    tangent, the partner at radius 0.1 facing it, both turning with the couple."""
    phi = np.linspace(0.0, 1.5 * math.pi, n)
    base = 0.7 * np.stack([np.cos(phi), np.sin(phi)], axis=1)
    torso = 0.1 * np.stack([np.cos(phi + math.pi), np.sin(phi + math.pi)], axis=1)
    return base, phi + 0.5 * math.pi, torso, phi - 0.5 * math.pi


def test_couple_turning_together_has_no_drift() -> None:
    base, base_yaw, torso, torso_yaw = _circle()
    out = relative_drift(base, base_yaw, torso, torso_yaw)
    assert out["relative_position_max"] == pytest.approx(0.0, abs=1e-12)
    assert out["relative_heading_max"] == pytest.approx(0.0, abs=1e-9)
    assert out["partner_turn_ccw"] == pytest.approx(270.0)
    assert out["robot_turn_ccw"] == pytest.approx(270.0)
    assert out["partner_turn_cw"] == 0.0


def test_motionless_robot_sees_the_whole_turn_and_path() -> None:
    """Partner turning 270° about the origin 0.1 m away, the robot still at (0.7, 0): heading
    drift 270°, position drift up to the circle's diameter 0.2 m (angle sweeps past 180°)."""
    _, _, torso, torso_yaw = _circle()
    n = torso.shape[0]
    base = np.tile([0.7, 0.0], (n, 1))
    out = relative_drift(base, np.zeros(n), torso, torso_yaw)
    assert out["relative_heading_max"] == pytest.approx(270.0)
    assert out["relative_position_max"] == pytest.approx(0.2, abs=1e-4)
    assert out["robot_turn_ccw"] == 0.0
