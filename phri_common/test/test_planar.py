"""Base-yaw rotation and planar headings: analytic cases, an independent reference (scipy's
Rotation), and round trips."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from phri_common.planar import (
    base_to_world,
    quaternion_from_yaw,
    world_to_base,
    yaw_from_quaternion,
)

angles = st.floats(-10.0, 10.0, allow_nan=False)
components = st.floats(-100.0, 100.0, allow_nan=False)
SQRT_HALF = math.sqrt(0.5)


@pytest.mark.parametrize(("yaw", "body", "world"), [
    (0.0, (1.0, 2.0), (1.0, 2.0)),
    (math.pi / 2, (1.0, 0.0), (0.0, 1.0)),       # base facing +y: forward is world +y
    (math.pi / 2, (0.0, 1.0), (-1.0, 0.0)),      # its left is world −x
    (math.pi, (1.0, 2.0), (-1.0, -2.0)),
    (-math.pi / 2, (0.0, -10.0), (-10.0, 0.0)),  # waltz force "to the right" at ψ = −90°
    (math.pi / 4, (1.0, 0.0), (SQRT_HALF, SQRT_HALF)),
])
def test_base_to_world_analytic(yaw: float, body: tuple[float, float],
                                world: tuple[float, float]) -> None:
    assert base_to_world(yaw, *body) == pytest.approx(world, abs=1e-12)
    assert world_to_base(yaw, *world) == pytest.approx(body, abs=1e-12)


@settings(max_examples=100, deadline=None)
@given(angles, components, components)
def test_base_to_world_adds_the_heading_to_the_polar_angle(yaw: float, vx: float,
                                                           vy: float) -> None:
    """Polar form as the oracle: rotating by ψ keeps the length and adds ψ to the angle."""
    r, theta = math.hypot(vx, vy), math.atan2(vy, vx)
    expected = (r * math.cos(theta + yaw), r * math.sin(theta + yaw))
    assert base_to_world(yaw, vx, vy) == pytest.approx(expected, abs=1e-9)


@settings(max_examples=100, deadline=None)
@given(angles, angles, components, components)
def test_round_trips_and_composition(a: float, b: float, vx: float, vy: float) -> None:
    assert world_to_base(a, *base_to_world(a, vx, vy)) == pytest.approx((vx, vy), abs=1e-9)
    assert base_to_world(a, *world_to_base(a, vx, vy)) == pytest.approx((vx, vy), abs=1e-9)
    assert base_to_world(a, *base_to_world(b, vx, vy)) == pytest.approx(
        base_to_world(a + b, vx, vy), abs=1e-9)


@pytest.mark.parametrize(("quaternion", "yaw"), [
    ((1.0, 0.0, 0.0, 0.0), 0.0),
    ((SQRT_HALF, 0.0, 0.0, SQRT_HALF), math.pi / 2),
    ((SQRT_HALF, 0.0, 0.0, -SQRT_HALF), -math.pi / 2),
    ((0.0, 0.0, 0.0, 1.0), math.pi),
    ((-1.0, 0.0, 0.0, 0.0), 0.0),                  # −q is the same rotation
    ((SQRT_HALF, SQRT_HALF, 0.0, 0.0), 0.0),       # roll by 90°: heading unchanged
])
def test_yaw_from_quaternion_analytic(quaternion: tuple[float, float, float, float],
                                      yaw: float) -> None:
    assert yaw_from_quaternion(*quaternion) == pytest.approx(yaw, abs=1e-12)


@settings(max_examples=100, deadline=None)
@given(st.lists(st.floats(-1.0, 1.0, allow_nan=False), min_size=4, max_size=4))
def test_yaw_from_quaternion_matches_scipy(q: list[float]) -> None:
    """Any unit quaternion: the Z of scipy's intrinsic Z-Y-X Euler angles."""
    v = np.array(q)
    if np.linalg.norm(v) < 0.1:
        return
    w, x, y, z = v / np.linalg.norm(v)
    rot = Rotation.from_quat([x, y, z, w])
    if abs(rot.as_matrix()[2, 0]) > 0.999:  # pitch ±90°, gimbal lock: yaw is not defined
        return
    expected = rot.as_euler("ZYX")[0]
    got = yaw_from_quaternion(w, x, y, z)
    assert math.remainder(got - expected, 2 * math.pi) == pytest.approx(0.0, abs=1e-9)


@settings(max_examples=100, deadline=None)
@given(angles)
def test_quaternion_from_yaw_round_trip_and_scipy(yaw: float) -> None:
    w, x, y, z = quaternion_from_yaw(yaw)
    assert math.remainder(yaw_from_quaternion(w, x, y, z) - yaw, 2 * math.pi) == pytest.approx(
        0.0, abs=1e-9)
    ref = Rotation.from_euler("z", yaw).as_quat()  # (x, y, z, w)
    sign = 1.0 if ref[3] * w + ref[2] * z >= 0.0 else -1.0
    np.testing.assert_allclose(sign * np.array([x, y, z, w]), ref, atol=1e-12)
