"""The test stand-in kinematics: its point Jacobian against finite differences of its FK."""

from __future__ import annotations

import numpy as np
from wbc_fake_kinematics import FakeKinematics
from wbc_rotations import log_rotation


def test_point_jacobian_matches_finite_differences() -> None:
    kin = FakeKinematics()
    rng = np.random.default_rng(0)
    q0 = rng.uniform(-1.5, 1.5, 15)
    point = np.array([0.1, -0.05, 0.07])
    for link in ("left_upper_arm_link", "left_forearm_link", "right_forearm_link"):
        kin.update(q0)
        jac = kin.point_jacobian(link, point)
        h = 1e-6
        for i in range(15):
            dq = np.zeros(15)
            dq[i] = h
            kin.update(q0 + dq)
            r1, p1 = kin.link_pose(link)
            kin.update(q0 - dq)
            r0, p0 = kin.link_pose(link)
            np.testing.assert_allclose((r1 @ point + p1 - r0 @ point - p0) / (2 * h), jac[0:3, i],
                                       atol=1e-7)
            np.testing.assert_allclose(log_rotation(r1 @ r0.T) / (2 * h), jac[3:6, i], atol=1e-7)
