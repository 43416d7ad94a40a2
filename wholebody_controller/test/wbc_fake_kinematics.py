"""A MuJoCo-free stand-in for ``RobotKinematics``: planar base + two UR16e DH chains.

Forward kinematics from the standard DH product and the geometric (analytic) Jacobian
``[z × (p − o); z]`` per revolute joint. Test-only; its Jacobian is itself checked against finite
differences in ``test_fake_kinematics.py``.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

Array = NDArray[np.float64]

UR16E_D = (0.1807, 0.0, 0.0, 0.17415, 0.11985, 0.11655)
UR16E_A = (0.0, -0.4784, -0.36, 0.0, 0.0, 0.0)
UR16E_ALPHA = (math.pi / 2, 0.0, 0.0, math.pi / 2, -math.pi / 2, 0.0)
ARM_JOINTS = (
    "shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint",
    "wrist_1_joint", "wrist_2_joint", "wrist_3_joint",
)
LINKS = ("shoulder_link", "upper_arm_link", "forearm_link", "wrist_1_link", "wrist_2_link",
         "wrist_3_link")
MOUNTS = {"left": np.array([0.15, 0.25, 0.9]), "right": np.array([0.15, -0.25, 0.9])}


def _dh(theta: float, d: float, a: float, alpha: float) -> Array:
    ct, st, ca, sa = math.cos(theta), math.sin(theta), math.cos(alpha), math.sin(alpha)
    return np.array([
        [ct, -st * ca, st * sa, a * ct],
        [st, ct * ca, -ct * sa, a * st],
        [0.0, sa, ca, d],
        [0.0, 0.0, 0.0, 1.0],
    ])


class FakeKinematics:
    """Same interface as ``wholebody_controller.kinematics.RobotKinematics``."""

    def __init__(self) -> None:
        self.joint_names = ["base_x", "base_y", "base_yaw"] + [
            f"{side}_{j}" for side in ("left", "right") for j in ARM_JOINTS
        ]
        n = len(self.joint_names)
        self.position_limits = np.tile([-2 * math.pi, 2 * math.pi], (n, 1))
        self.position_limits[0:3] = [-math.inf, math.inf]
        self.position_limits[[5, 11]] = [-math.pi, math.pi]
        self.velocity_limits = np.array([1.0, 1.0, 1.0] + [2.094, 2.094] + [3.14] * 4
                                        + [2.094, 2.094] + [3.14] * 4)
        self._frames: dict[str, tuple[int, int, list[Array]]] = {}
        self.update(np.zeros(n))

    def update(self, q: Array) -> None:
        q = np.asarray(q, dtype=float)
        self._q = q.copy()
        x, y, yaw = q[0:3]
        base = np.eye(4)
        c, s = math.cos(yaw), math.sin(yaw)
        base[0:2, 0:2] = [[c, -s], [s, c]]
        base[0:2, 3] = [x, y]
        self._base = base
        self._chains: dict[str, list[Array]] = {}
        for k, side in enumerate(("left", "right")):
            mount = np.eye(4)
            mount[0:3, 3] = MOUNTS[side]
            frames = [base @ mount]
            for i in range(6):
                qi = q[3 + 6 * k + i]
                frames.append(frames[-1] @ _dh(qi, UR16E_D[i], UR16E_A[i], UR16E_ALPHA[i]))
            self._chains[side] = frames

    def _locate(self, link: str) -> tuple[str, int, int]:
        side, _, name = link.partition("_")
        if side not in ("left", "right") or name not in LINKS:
            raise KeyError(link)
        return side, LINKS.index(name) + 1, 3 + (0 if side == "left" else 6)

    def link_pose(self, link: str) -> tuple[Array, Array]:
        side, k, _ = self._locate(link)
        t = self._chains[side][k]
        return t[0:3, 0:3].copy(), t[0:3, 3].copy()

    def link_pose_floats(self, link: str) -> tuple[list[float], list[float]]:
        rot, pos = self.link_pose(link)
        return rot.ravel().tolist(), pos.tolist()

    def point_jacobian(self, link: str, point: Array, out: Array | None = None) -> Array:
        side, k, offset = self._locate(link)
        frames = self._chains[side]
        t = frames[k]
        p = t[0:3, 0:3] @ np.asarray(point, dtype=float) + t[0:3, 3]
        jac = np.zeros((6, len(self.joint_names)))
        jac[0, 0] = 1.0
        jac[1, 1] = 1.0
        ez = np.array([0.0, 0.0, 1.0])
        jac[0:3, 2] = np.cross(ez, p - self._base[0:3, 3])
        jac[3:6, 2] = ez
        for j in range(k):
            z = frames[j][0:3, 2]
            o = frames[j][0:3, 3]
            jac[0:3, offset + j] = np.cross(z, p - o)
            jac[3:6, offset + j] = z
        if out is not None:
            out[...] = jac
            return out
        return jac
