"""Small rigid-transform helpers shared by the description and its generators (pure numpy)."""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

Mat3 = NDArray[np.float64]
Vec3 = NDArray[np.float64]


def rot_x(angle: float) -> Mat3:
    """Rotation matrix about x by ``angle`` [rad]."""
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def rot_y(angle: float) -> Mat3:
    """Rotation matrix about y by ``angle`` [rad]."""
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def rot_z(angle: float) -> Mat3:
    """Rotation matrix about z by ``angle`` [rad]."""
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def axis_angle(axis: Vec3, angle: float) -> Mat3:
    """Rodrigues' rotation about the unit vector ``axis`` by ``angle`` [rad]."""
    k = np.asarray(axis, dtype=float)
    k = k / np.linalg.norm(k)
    kx = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return np.eye(3) + math.sin(angle) * kx + (1.0 - math.cos(angle)) * (kx @ kx)


def z_to(direction: Vec3) -> Mat3:
    """The smallest rotation that maps +z onto the unit vector ``direction``.

    Cylinders are modelled along their local z axis in both URDF and MuJoCo; this orients one.
    """
    d = np.asarray(direction, dtype=float)
    d = d / np.linalg.norm(d)
    z = np.array([0.0, 0.0, 1.0])
    cross = np.cross(z, d)
    s = float(np.linalg.norm(cross))
    c = float(d[2])
    if s < 1e-12:
        return np.eye(3) if c > 0.0 else rot_x(math.pi)
    return axis_angle(cross / s, math.atan2(s, c))


def rpy_from_matrix(r: Mat3) -> tuple[float, float, float]:
    """URDF roll-pitch-yaw [rad] of ``r`` = Rz(yaw) · Ry(pitch) · Rx(roll)."""
    pitch = math.atan2(-r[2, 0], math.hypot(r[0, 0], r[1, 0]))
    if math.cos(pitch) > 1e-9:
        roll = math.atan2(r[2, 1], r[2, 2])
        yaw = math.atan2(r[1, 0], r[0, 0])
    else:  # gimbal lock: only roll ± yaw is defined; put it all in yaw
        roll = 0.0
        yaw = math.atan2(-r[0, 1], r[1, 1])
    return roll, pitch, yaw


def matrix_from_rpy(roll: float, pitch: float, yaw: float) -> Mat3:
    """Inverse of :func:`rpy_from_matrix` (URDF convention)."""
    return rot_z(yaw) @ rot_y(pitch) @ rot_x(roll)


def quat_from_matrix(r: Mat3) -> NDArray[np.float64]:
    """Unit quaternion [w, x, y, z] (MuJoCo order) of the rotation matrix ``r``."""
    m = np.asarray(r, dtype=float)
    tr = m[0, 0] + m[1, 1] + m[2, 2]
    if tr > 0.0:
        s = 2.0 * math.sqrt(1.0 + tr)
        q = [0.25 * s, (m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s]
    elif m[0, 0] > m[1, 1] and m[0, 0] > m[2, 2]:
        s = 2.0 * math.sqrt(1.0 + m[0, 0] - m[1, 1] - m[2, 2])
        q = [(m[2, 1] - m[1, 2]) / s, 0.25 * s, (m[0, 1] + m[1, 0]) / s, (m[0, 2] + m[2, 0]) / s]
    elif m[1, 1] > m[2, 2]:
        s = 2.0 * math.sqrt(1.0 + m[1, 1] - m[0, 0] - m[2, 2])
        q = [(m[0, 2] - m[2, 0]) / s, (m[0, 1] + m[1, 0]) / s, 0.25 * s, (m[1, 2] + m[2, 1]) / s]
    else:
        s = 2.0 * math.sqrt(1.0 + m[2, 2] - m[0, 0] - m[1, 1])
        q = [(m[1, 0] - m[0, 1]) / s, (m[0, 2] + m[2, 0]) / s, (m[1, 2] + m[2, 1]) / s, 0.25 * s]
    quat = np.array(q)
    quat /= np.linalg.norm(quat)
    return quat if quat[0] >= 0.0 else -quat


def homogeneous(r: Mat3, p: Vec3) -> NDArray[np.float64]:
    """4×4 homogeneous transform from rotation ``r`` and translation ``p`` [m]."""
    t = np.eye(4)
    t[:3, :3] = r
    t[:3, 3] = p
    return t
