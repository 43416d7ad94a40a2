"""RobotKinematics against independent D-H forward kinematics and finite differences.

The reference numbers below are typed in from design §5 (UR16e D-H table, limits) and from the
documented mounting poses (docs/robot_description.md), not read from the code under test.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from phri_description.mujoco_model import build_spec
from wholebody_controller.kinematics import (
    RobotKinematics,
    base_rates_from_twist,
    base_twist_from_rates,
)

# design §5
D = [0.1807, 0.0, 0.0, 0.17415, 0.11985, 0.11655]
A = [0.0, -0.4784, -0.36, 0.0, 0.0, 0.0]
ALPHA = [math.pi / 2, 0.0, 0.0, math.pi / 2, -math.pi / 2, 0.0]
UR_LINKS = ["shoulder_link", "upper_arm_link", "forearm_link", "wrist_1_link", "wrist_2_link",
            "wrist_3_link"]
# docs/robot_description.md: torso_link 0.40 m above base_link; arm base frames in torso_link at
# (0, ±0.15, 0.70) with z0 = ±y (outward) and x0 = −x (backward).
TORSO_Z = 0.40
MOUNT = {
    "left": (np.array([0.0, 0.15, 0.70]), np.array([[-1.0, 0, 0], [0, 0, 1.0], [0, 1.0, 0]])),
    "right": (np.array([0.0, -0.15, 0.70]), np.array([[-1.0, 0, 0], [0, 0, -1.0], [0, -1.0, 0]])),
}


def tf(r: np.ndarray, p: np.ndarray) -> np.ndarray:
    t = np.eye(4)
    t[:3, :3], t[:3, 3] = r, p
    return t


def dh(theta: float, d: float, a: float, alpha: float) -> np.ndarray:
    """Standard D-H: Rz(θ)·Tz(d)·Tx(a)·Rx(α), written out."""
    ct, st, ca, sa = math.cos(theta), math.sin(theta), math.cos(alpha), math.sin(alpha)
    return np.array(
        [
            [ct, -st * ca, st * sa, a * ct],
            [st, ct * ca, -ct * sa, a * st],
            [0.0, sa, ca, d],
            [0.0, 0.0, 0.0, 1.0],
        ]
    )


def reference_frames(q: np.ndarray, side: str) -> list[np.ndarray]:
    """World poses of D-H frames 0..6 of one arm."""
    x, y, yaw = q[:3]
    c, s = math.cos(yaw), math.sin(yaw)
    base = tf(np.array([[c, -s, 0], [s, c, 0], [0, 0, 1.0]]), np.array([x, y, 0.0]))
    torso = base @ tf(np.eye(3), np.array([0.0, 0.0, TORSO_Z]))
    p, r = MOUNT[side]
    t = torso @ tf(r, p)
    frames = [t]
    qa = q[3:9] if side == "left" else q[9:15]
    for i in range(6):
        t = t @ dh(qa[i], D[i], A[i], ALPHA[i])
        frames.append(t)
    return frames


def random_q(rng: np.random.Generator) -> np.ndarray:
    q = np.empty(15)
    q[:2] = rng.uniform(-3.0, 3.0, 2)
    q[2] = rng.uniform(-math.pi, math.pi)
    q[3:] = rng.uniform(-math.pi, math.pi, 12)
    return q


@pytest.fixture(scope="module")
def kin() -> RobotKinematics:
    return RobotKinematics()


def test_joint_names_and_order(kin: RobotKinematics) -> None:
    arm = ["shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint",
           "wrist_2_joint", "wrist_3_joint"]
    expected = ["base_x", "base_y", "base_yaw"]
    expected += [f"{s}_{j}" for s in ("left", "right") for j in arm]
    assert list(kin.joint_names) == expected


@pytest.mark.parametrize("side", ["left", "right"])
def test_forward_kinematics_matches_dh(kin: RobotKinematics, side: str) -> None:
    rng = np.random.default_rng(7 if side == "left" else 8)
    for _ in range(50):
        q = random_q(rng)
        kin.update(q)
        frames = reference_frames(q, side)
        for i, name in enumerate(["base_link", *UR_LINKS]):
            r, p = kin.link_pose(f"{side}_{name}")
            np.testing.assert_allclose(p, frames[i][:3, 3], atol=1e-10, err_msg=name)
            np.testing.assert_allclose(r, frames[i][:3, :3], atol=1e-10, err_msg=name)
        r, p = kin.link_pose(f"{side}_tool0")
        np.testing.assert_allclose(p, frames[6][:3, 3], atol=1e-10)


def test_zero_configuration_reach(kin: RobotKinematics) -> None:
    """Analytic case: at q = 0 each arm points straight forward (−x0 = +x) at mount height;
    the flange is a2 + a3 ahead, d4 + d6 along z1, and d1 − d5 along the mount's outward axis
    (as on any UR at zero: the wrist-2 offset d5 points back towards the base axis)."""
    kin.update(np.zeros(15))
    _, p = kin.link_pose("left_tool0")
    # z1 = −y0 = −z for the left arm; outward (+y) by d1 − d5
    np.testing.assert_allclose(
        p, [0.4784 + 0.36, 0.15 + 0.1807 - 0.11985, 1.10 - 0.17415 - 0.11655], atol=1e-12
    )
    _, p = kin.link_pose("right_tool0")
    np.testing.assert_allclose(p, [0.4784 + 0.36, -0.15 - 0.1807 + 0.11985,
                                   1.10 + 0.17415 + 0.11655], atol=1e-12)


def so3_log(r: np.ndarray) -> np.ndarray:
    """Rotation vector of a rotation matrix (angles well below π here)."""
    angle = math.acos(max(-1.0, min(1.0, (np.trace(r) - 1.0) / 2.0)))
    w = np.array([r[2, 1] - r[1, 2], r[0, 2] - r[2, 0], r[1, 0] - r[0, 1]])
    if angle < 1e-12:
        return 0.5 * w
    return angle / (2.0 * math.sin(angle)) * w


LINKS = ["left_upper_arm_link", "left_forearm_link", "right_forearm_link", "left_wrist_3_link",
         "right_shoulder_link", "torso_link", "base_link"]


@pytest.mark.parametrize("link", LINKS)
def test_point_jacobian_matches_finite_differences(kin: RobotKinematics, link: str) -> None:
    rng = np.random.default_rng(LINKS.index(link) + 11)
    h = 1e-6
    for _ in range(8):
        q = random_q(rng)
        offset = rng.uniform(-0.3, 0.3, 3)
        kin.update(q)
        jac = kin.point_jacobian(link, offset).copy()
        numeric = np.zeros((6, 15))
        for k in range(15):
            dq = np.zeros(15)
            dq[k] = h
            kin.update(q + dq)
            r_p, _ = kin.link_pose(link)
            p_p = kin.point_position(link, offset)
            kin.update(q - dq)
            r_m, _ = kin.link_pose(link)
            p_m = kin.point_position(link, offset)
            numeric[:3, k] = (p_p - p_m) / (2 * h)
            numeric[3:, k] = so3_log(r_p @ r_m.T) / (2 * h)
        np.testing.assert_allclose(jac, numeric, atol=2e-7)


def test_point_jacobian_is_eq8(kin: RobotKinematics) -> None:
    """(8) with ᶦṗ_η = 0: J_p(η) = J_p(γ) − [⁰R ᶦp]× J_ω, same angular rows."""
    rng = np.random.default_rng(3)
    for _ in range(20):
        kin.update(random_q(rng))
        offset = rng.uniform(-0.2, 0.2, 3)
        r, _ = kin.link_pose("left_forearm_link")
        jf = kin.frame_jacobian("left_forearm_link")
        jp = kin.point_jacobian("left_forearm_link", offset)
        v = r @ offset
        skew = np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])
        np.testing.assert_allclose(jp[:3], jf[:3] - skew @ jf[3:], atol=1e-12)
        np.testing.assert_allclose(jp[3:], jf[3:], atol=1e-15)


def test_jacobian_structure(kin: RobotKinematics) -> None:
    """A left-arm link does not move with right-arm joints; base columns are planar motions."""
    rng = np.random.default_rng(4)
    q = random_q(rng)
    kin.update(q)
    j = kin.point_jacobian("left_forearm_link", [0.1, 0.0, 0.05])
    np.testing.assert_array_equal(j[:, 9:], 0.0)
    np.testing.assert_array_equal(j[:, 6:9], 0.0)  # wrist joints come after the forearm
    np.testing.assert_allclose(j[:, 0], [1, 0, 0, 0, 0, 0], atol=1e-15)
    np.testing.assert_allclose(j[:, 1], [0, 1, 0, 0, 0, 0], atol=1e-15)
    p = kin.point_position("left_forearm_link", [0.1, 0.0, 0.05])
    # yaw about the world z axis through the base origin (x, y)
    r = p - np.array([q[0], q[1], 0.0])
    np.testing.assert_allclose(j[:3, 2], np.cross([0, 0, 1.0], r), atol=1e-12)
    np.testing.assert_allclose(j[3:, 2], [0, 0, 1.0], atol=1e-15)


def test_out_argument_is_filled_in_place(kin: RobotKinematics) -> None:
    kin.update(random_q(np.random.default_rng(5)))
    out = np.full((6, 15), np.nan)
    res = kin.point_jacobian("right_forearm_link", [0.2, 0.0, 0.1], out=out)
    assert res is out
    np.testing.assert_array_equal(out, kin.point_jacobian("right_forearm_link", [0.2, 0.0, 0.1]))
    with pytest.raises(ValueError, match="shape"):
        kin.frame_jacobian("right_forearm_link", out=np.zeros((6, 14)))


def test_extended_model_gives_same_answers() -> None:
    """A simulator model with extra DOFs (a free-floating body) maps q and columns correctly."""
    spec = build_spec()
    body = spec.worldbody.add_body()
    body.name = "person"
    body.add_freejoint()
    g = body.add_geom()
    g.size = [0.1, 0, 0]
    g.mass = 1.0
    ext = RobotKinematics(model=spec.compile())
    assert ext.model.nq == 22
    ref = RobotKinematics()
    rng = np.random.default_rng(6)
    for _ in range(5):
        q = random_q(rng)
        ext.update(q)
        ref.update(q)
        for link in ("left_forearm_link", "right_wrist_3_link"):
            np.testing.assert_allclose(ext.link_pose(link)[1], ref.link_pose(link)[1], atol=1e-12)
            np.testing.assert_allclose(
                ext.point_jacobian(link, [0.1, 0.2, 0.0]),
                ref.point_jacobian(link, [0.1, 0.2, 0.0]),
                atol=1e-12,
            )


def test_bad_input_is_refused_and_state_kept(kin: RobotKinematics) -> None:
    q = random_q(np.random.default_rng(9))
    kin.update(q)
    before = kin.link_pose("left_forearm_link")[1]
    bad = q.copy()
    bad[4] = math.nan
    with pytest.raises(ValueError, match="left_shoulder_lift_joint"):
        kin.update(bad)
    bad[4] = math.inf
    with pytest.raises(ValueError, match="non-finite"):
        kin.update(bad)
    with pytest.raises(ValueError, match="shape"):
        kin.update(np.zeros(14))
    np.testing.assert_array_equal(kin.link_pose("left_forearm_link")[1], before)
    np.testing.assert_array_equal(kin.q, q)
    with pytest.raises(KeyError, match="unknown link"):
        kin.link_pose("left_hand")


def test_limits_match_design(kin: RobotKinematics) -> None:
    deg = math.pi / 180.0
    lim = kin.position_limits
    assert lim.shape == (15, 2)
    assert np.all(np.isinf(lim[:3, 0])) and np.all(lim[:3, 0] < 0) and np.all(np.isinf(lim[:3, 1]))
    arm_pos = [360, 360, 180, 360, 360, 360]
    arm_vel = [120, 120, 180, 180, 180, 180]
    for offset in (3, 9):
        np.testing.assert_allclose(lim[offset:offset + 6, 1], np.array(arm_pos) * deg)
        np.testing.assert_allclose(lim[offset:offset + 6, 0], -np.array(arm_pos) * deg)
        np.testing.assert_allclose(kin.velocity_limits[offset:offset + 6], np.array(arm_vel) * deg)
    assert kin.velocity_limits.shape == (15,)
    assert np.all(kin.velocity_limits[:3] > 0)


def test_base_twist_conversion() -> None:
    # facing +y (yaw = 90°): moving along world +x is moving to the base's right (−y_base)
    np.testing.assert_allclose(base_twist_from_rates(math.pi / 2, [1.0, 0.0, 0.3]),
                               [0.0, -1.0, 0.3], atol=1e-15)
    rng = np.random.default_rng(10)
    for _ in range(20):
        yaw = rng.uniform(-4, 4)
        t = rng.normal(size=3)
        np.testing.assert_allclose(base_twist_from_rates(yaw, base_rates_from_twist(yaw, t)), t,
                                   atol=1e-14)


def test_base_twist_agrees_with_jacobian(kin: RobotKinematics) -> None:
    """The base_link frame's world velocity from the Jacobian, seen in the base frame, is the
    twist that base_twist_from_rates computes."""
    rng = np.random.default_rng(11)
    q = random_q(rng)
    kin.update(q)
    rates = rng.normal(size=3)
    qd = np.zeros(15)
    qd[:3] = rates
    v = kin.frame_jacobian("base_link") @ qd
    r, _ = kin.link_pose("base_link")
    body = r.T @ v[:3]
    np.testing.assert_allclose([body[0], body[1], v[5]], base_twist_from_rates(q[2], rates),
                               atol=1e-12)
    assert abs(body[2]) < 1e-12


def test_model_compiles_without_warnings() -> None:
    kin = RobotKinematics()
    kin.update(np.zeros(15))
    mujoco.mj_forward(kin.model, kin.data)
    assert int(kin.data.warning.number.sum()) == 0
