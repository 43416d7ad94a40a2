"""The robot description, its URDF and MuJoCo model agree with the UR16e D-H table (design §5)."""

from __future__ import annotations

import math
import re
import xml.etree.ElementTree as ET

import mujoco
import numpy as np
import pytest

from phri_common.testing import assert_generated_file
from phri_description.description import (
    JOINT_NAMES,
    SKIN_LINKS,
    SKIN_PATCHES,
    robot_description,
)
from phri_description.mujoco_model import build_model
from phri_description.urdf_writer import (
    load_patches_yaml,
    patches_path,
    patches_yaml,
    urdf_path,
    urdf_string,
)

REGENERATE = ".venv/bin/python -m phri_description.urdf_writer"

# design §5, written out again here so the test does not read the values it checks
D = [0.1807, 0.0, 0.0, 0.17415, 0.11985, 0.11655]
A = [0.0, -0.4784, -0.36, 0.0, 0.0, 0.0]
ALPHA = [math.pi / 2, 0.0, 0.0, math.pi / 2, -math.pi / 2, 0.0]
VEL = [math.radians(v) for v in (120, 120, 180, 180, 180, 180)]
POS = [2 * math.pi, 2 * math.pi, math.pi, 2 * math.pi, 2 * math.pi, 2 * math.pi]
UR_JOINTS = ["shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint",
             "wrist_2_joint", "wrist_3_joint"]
UR_LINKS = ["shoulder_link", "upper_arm_link", "forearm_link", "wrist_1_link", "wrist_2_link",
            "wrist_3_link"]
MASSES = [7.369, 10.450, 4.321, 2.180, 2.033, 0.907]


def dh(theta: float, d: float, a: float, alpha: float) -> np.ndarray:
    ct, st, ca, sa = math.cos(theta), math.sin(theta), math.cos(alpha), math.sin(alpha)
    return np.array([[ct, -st * ca, st * sa, a * ct], [st, ct * ca, -ct * sa, a * st],
                     [0.0, sa, ca, d], [0.0, 0.0, 0.0, 1.0]])


def rpy_matrix(roll: float, pitch: float, yaw: float) -> np.ndarray:
    cr, sr, cp, sp, cy, sy = (math.cos(roll), math.sin(roll), math.cos(pitch), math.sin(pitch),
                              math.cos(yaw), math.sin(yaw))
    rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
    rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
    return rz @ ry @ rx


def axis_motion(kind: str, axis: np.ndarray, q: float) -> np.ndarray:
    t = np.eye(4)
    if kind == "prismatic":
        t[:3, 3] = axis * q
        return t
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    t[:3, :3] = np.eye(3) + math.sin(q) * k + (1 - math.cos(q)) * k @ k  # Rodrigues
    return t


def urdf_link_poses(root: ET.Element, q: dict[str, float]) -> dict[str, np.ndarray]:
    """World pose of every URDF link, composing origin · motion along the joint tree."""
    joints = {j.find("child").get("link"): j for j in root.iter("joint")}  # type: ignore[union-attr]
    poses: dict[str, np.ndarray] = {}

    def pose(link: str) -> np.ndarray:
        if link in poses:
            return poses[link]
        joint = joints.get(link)
        if joint is None:
            poses[link] = np.eye(4)
            return poses[link]
        origin = joint.find("origin")
        t = np.eye(4)
        if origin is not None:
            t[:3, 3] = [float(v) for v in origin.get("xyz", "0 0 0").split()]
            t[:3, :3] = rpy_matrix(*[float(v) for v in origin.get("rpy", "0 0 0").split()])
        kind = joint.get("type", "fixed")
        if kind != "fixed":
            axis = np.array([float(v) for v in joint.find("axis").get("xyz").split()])  # type: ignore[union-attr]
            t = t @ axis_motion(kind, axis, q[joint.get("name", "")])
        parent = joint.find("parent").get("link")  # type: ignore[union-attr]
        poses[link] = pose(parent) @ t  # type: ignore[arg-type]
        return poses[link]

    for link in root.iter("link"):
        pose(link.get("name", ""))
    return poses


def test_checked_in_urdf_is_the_generated_one() -> None:
    assert_generated_file(urdf_path(), urdf_string(), REGENERATE)


def test_urdf_writes_arithmetic_noise_as_zero() -> None:
    """A generated file must not depend on the last bits of a machine's arithmetic: the base's
    centre of mass and the arm mounts' roll come out of products of rotations as 1e-16…1e-20 on
    some machines and 0 on others; the file writes 0."""
    text = urdf_string()
    assert '<origin xyz="0 0.15 0.7" rpy="1.57079633 0 3.14159265"/>' in text
    assert not re.search(r"\de-(1\d|[2-9]\d)\b", text), "noise below 1e-9 written as a number"


def test_urdf_declares_the_joints_and_limits_of_design_5() -> None:
    root = ET.fromstring(urdf_string())
    moving = {j.get("name"): j for j in root.iter("joint") if j.get("type") != "fixed"}
    assert set(moving) == set(JOINT_NAMES)
    for side in ("left", "right"):
        for i, name in enumerate(UR_JOINTS):
            limit = moving[f"{side}_{name}"].find("limit")
            assert limit is not None
            assert float(limit.get("velocity", "nan")) == pytest.approx(VEL[i])
            assert float(limit.get("upper", "nan")) == pytest.approx(POS[i])
            assert float(limit.get("lower", "nan")) == pytest.approx(-POS[i])
    links = {link.get("name") for link in root.iter("link")}
    assert set(SKIN_LINKS) <= links


def test_urdf_link_frames_are_the_dh_frames() -> None:
    root = ET.fromstring(urdf_string())
    rng = np.random.default_rng(3)
    for _ in range(20):
        values = rng.uniform(-math.pi, math.pi, len(JOINT_NAMES))
        q = dict(zip(JOINT_NAMES, values, strict=True))
        poses = urdf_link_poses(root, q)
        for side in ("left", "right"):
            frame = poses[f"{side}_base_link"]  # D-H frame 0 (mounting checked in kinematics)
            for i, link in enumerate(UR_LINKS):
                frame = frame @ dh(q[f"{side}_{UR_JOINTS[i]}"], D[i], A[i], ALPHA[i])
                np.testing.assert_allclose(poses[f"{side}_{link}"], frame, atol=1e-7,
                                           err_msg=f"{side}_{link}")
        # the planar base: x, y in odom, then yaw
        base = poses["base_link"]
        np.testing.assert_allclose(base[:2, 3], [q["base_x"], q["base_y"]], atol=1e-9)
        assert math.atan2(base[1, 0], base[0, 0]) == pytest.approx(
            math.atan2(math.sin(q["base_yaw"]), math.cos(q["base_yaw"])))


def test_mujoco_joint_ranges_are_radians() -> None:
    # Regression: MjSpec defaults to degrees; ±2π compiled as ±6.28° before the fix.
    model = build_model()
    for side in ("left", "right"):
        for i, name in enumerate(UR_JOINTS):
            jid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, f"{side}_{name}")
            np.testing.assert_allclose(model.jnt_range[jid], [-POS[i], POS[i]])


def test_skin_patches_are_on_the_three_skin_links() -> None:
    """Paper III-A: skin on two links of the left arm and one of the right (names typed here)."""
    assert SKIN_PATCHES == ("left_upper_arm", "left_forearm", "right_forearm")
    assert SKIN_LINKS == ("left_upper_arm_link", "left_forearm_link", "right_forearm_link")
    patches = robot_description().patches
    assert [(p.name, p.link) for p in patches] == list(zip(SKIN_PATCHES, SKIN_LINKS, strict=True))


def test_checked_in_patch_yaml_is_the_generated_one_and_round_trips() -> None:
    assert_generated_file(patches_path(), patches_yaml(), REGENERATE)
    text = patches_path().read_text(encoding="utf-8")
    assert load_patches_yaml(text) == list(robot_description().patches)


def test_patches_lie_on_their_links_collision_cylinders() -> None:
    """Each patch's cylinder is one collision cylinder of its link in the URDF (same axis line,
    same radius, axial range inside its length), so taxels sit on the collision surface."""
    root = ET.parse(urdf_path()).getroot()
    links = {link.get("name"): link for link in root.iter("link")}
    for p in robot_description().patches:
        axis, point = np.array(p.axis), np.array(p.point)
        matches = 0
        for col in links[p.link].iter("collision"):
            cyl = col.find("geometry/cylinder")
            origin = col.find("origin")
            if cyl is None or origin is None:
                continue
            rot = rpy_matrix(*[float(v) for v in origin.get("rpy", "0 0 0").split()])
            centre = np.array([float(v) for v in origin.get("xyz", "0 0 0").split()])
            c_axis = rot[:, 2]
            off = point - centre
            if (abs(abs(c_axis @ axis) - 1.0) > 1e-9
                    or np.linalg.norm(off - (off @ c_axis) * c_axis) > 1e-9
                    or abs(float(cyl.get("radius", "0")) - p.radius) > 1e-9):
                continue
            half = float(cyl.get("length", "0")) / 2.0
            for s_ in p.axial_range:
                assert abs((point + s_ * axis - centre) @ c_axis) <= half + 1e-9, p.name
            matches += 1
        assert matches == 1, p.name
        rng = np.random.default_rng(2)
        for _ in range(20):
            s_, phi = rng.uniform(*p.axial_range), rng.uniform(*p.angular_range)
            n = p.normal(phi)
            assert np.linalg.norm(n) == pytest.approx(1.0) and abs(n @ axis) < 1e-12
            x = p.surface_point(s_, phi) - point
            np.testing.assert_allclose(x - (x @ axis) * axis, p.radius * n, atol=1e-12)
        np.testing.assert_allclose(p.normal(0.0), p.zero_direction, atol=1e-15)
        np.testing.assert_allclose(p.normal(math.pi / 2), np.cross(axis, p.zero_direction),
                                   atol=1e-15)
        # about 2,000 taxels of 7.5 mm per patch (design §7: 3 × 2,000 taxels)
        assert 1000 < p.area() / 0.0075**2 < 3000


def test_urdf_and_mujoco_masses_match_design_and_inertias_are_physical() -> None:
    root = ET.parse(urdf_path()).getroot()
    links = {link.get("name"): link for link in root.iter("link")}
    model = build_model()
    for side in ("left", "right"):
        for link, mass in zip(UR_LINKS, MASSES, strict=True):
            inertial = links[f"{side}_{link}"].find("inertial")
            assert inertial is not None
            assert float(inertial.find("mass").get("value", "0")) == pytest.approx(mass)  # type: ignore[union-attr]
            g = {k: float(v) for k, v in inertial.find("inertia").attrib.items()}  # type: ignore[union-attr]
            tensor = np.array([[g["ixx"], g["ixy"], g["ixz"]], [g["ixy"], g["iyy"], g["iyz"]],
                               [g["ixz"], g["iyz"], g["izz"]]])
            ev = np.linalg.eigvalsh(tensor)
            assert ev[0] > 0 and ev[0] + ev[1] >= ev[2] * (1 - 1e-9)
            assert model.body(f"{side}_{link}").mass[0] == pytest.approx(mass)


def test_mujoco_model_steps_without_warnings() -> None:
    model = build_model()
    data = mujoco.MjData(model)
    assert [model.joint(i).name for i in range(model.njnt)] == list(JOINT_NAMES)
    for _ in range(200):
        mujoco.mj_step(model, data)
    assert int(data.warning.number.sum()) == 0
    assert np.all(np.isfinite(data.qpos))


# Universal Robots' UR16e dynamics, D-H frames: ur_description config/ur16e/physical_parameters.yaml
# (mass; centre of mass as the "model" values its comments give; tensor about the centre of
# mass in axes rotated by its `rotation` = the D-H α), typed in here from that file.
UR16E_REFERENCE = {
    "shoulder_link": (7.369, (0.0, -0.016, 0.030),
                      (0.03351, 0.03374, 0.02100, 0.00002, -0.00001, 0.00374)),
    "upper_arm_link": (10.450, (0.302, 0.0, 0.16),
                       (0.02796, 0.47558, 0.47635, -0.00010, -0.00720, 0.00003)),
    "forearm_link": (4.321, (0.194, 0.0, 0.065),
                     (0.01091, 0.12060, 0.11714, 0.00006, 0.01012, 0.00001)),
    "wrist_1_link": (2.180, (0.0, -0.009, 0.011),
                     (0.00609, 0.00245, 0.00579, -0.00001, 0.0, 0.00083)),
    "wrist_2_link": (2.033, (0.0, 0.018, 0.012),
                     (0.00389, 0.00219, 0.00363, -0.00001, 0.0, -0.00045)),
    "wrist_3_link": (0.907, (0.0, 0.0, -0.044), (0.00117, 0.00118, 0.00084, 0.0, 0.0, 0.0)),
}


@pytest.mark.parametrize("side", ["left", "right"])
def test_arm_inertials_are_the_official_ur16e_values(side: str) -> None:
    """URDF and MuJoCo carry UR's published mass, centre of mass and inertia per arm link."""
    import xml.etree.ElementTree as ET

    from phri_description.mujoco_model import build_model
    links = {lk.get("name"): lk for lk in ET.parse(urdf_path()).getroot().iter("link")}
    model = build_model()
    for link, (mass, com, (ixx, iyy, izz, ixy, ixz, iyz)) in UR16E_REFERENCE.items():
        inertial = links[f"{side}_{link}"].find("inertial")
        assert inertial is not None
        assert float(inertial.find("mass").get("value", "")) == pytest.approx(mass)  # type: ignore[union-attr]
        xyz = [float(v) for v in inertial.find("origin").get("xyz", "").split()]  # type: ignore[union-attr]
        assert xyz == pytest.approx(com, abs=1e-9)
        got = {k: float(v) for k, v in inertial.find("inertia").attrib.items()}  # type: ignore[union-attr]
        want = {"ixx": ixx, "iyy": iyy, "izz": izz, "ixy": ixy, "ixz": ixz, "iyz": iyz}
        assert got == pytest.approx(want, abs=1e-12)
        # MuJoCo: same mass and centre; principal moments = eigenvalues of the tensor.
        body = model.body(f"{side}_{link}")
        assert body.mass[0] == pytest.approx(mass)
        assert body.ipos == pytest.approx(com, abs=1e-9)
        tensor = np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]])
        assert sorted(body.inertia) == pytest.approx(sorted(np.linalg.eigvalsh(tensor)), rel=1e-6)
