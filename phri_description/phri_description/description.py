"""THE description of the dual-arm mobile manipulator: one source for URDF, MuJoCo and kinematics.

The robot (paper Section III-A): an omnidirectional mecanum base, a torso column and two UR16e
arms; electronic skin on three links (left upper arm, left forearm, right forearm).

Kinematic tree (frames; every arm frame is a D-H frame, paper III-A: "we chose the link's
reference frame as defined by the D-H table")::

    odom ─base_x (prismatic, odom x)─► base_x_link ─base_y (prismatic, odom y)─► base_y_link
         ─base_yaw (revolute, z)─► base_link ─fixed─► torso_link
         ─fixed (mount)─► <side>_base_link  (UR D-H frame 0)
         ─<side>_shoulder_pan_joint─► <side>_shoulder_link   (D-H frame 1)
         ─<side>_shoulder_lift_joint─► <side>_upper_arm_link (D-H frame 2)
         ─<side>_elbow_joint─►         <side>_forearm_link   (D-H frame 3)
         ─<side>_wrist_1_joint─►       <side>_wrist_1_link   (D-H frame 4)
         ─<side>_wrist_2_joint─►       <side>_wrist_2_link   (D-H frame 5)
         ─<side>_wrist_3_joint─►       <side>_wrist_3_link   (D-H frame 6)
         ─fixed─► <side>_tool0 (= D-H frame 6, UR's flange frame)

Every joint is stored the D-H way: the child frame is ``parent · Motion(axis, q) · offset`` with
the motion about (or along) ``axis`` through the parent frame's origin, then a constant
``offset``. For UR joint i: ``Motion = Rz(q_i)``, ``offset = Tz(d_i) · Tx(a_i) · Rx(α_i)``. The
URDF writer and the MuJoCo builder translate this form; nothing else about the robot is stated
twice.

Note: ``<side>_base_link`` here is UR's D-H base frame, i.e. the frame ur_description calls
``base``; ur_description's own ``base_link`` is rotated by π about z from it. Likewise the UR link
frames below are D-H frames, not ur_description's joint-located link frames.

All lengths in [m], angles in [rad], masses in [kg].
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from functools import cache
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from phri_description.transforms import rot_x, rot_z, z_to

Vec3 = tuple[float, float, float]
Mat3T = tuple[Vec3, Vec3, Vec3]

# ---------------------------------------------------------------------------------------------
# UR16e (design §5, Universal_Robots_ROS2_Description)
# ---------------------------------------------------------------------------------------------

UR16E_D: tuple[float, ...] = (0.1807, 0.0, 0.0, 0.17415, 0.11985, 0.11655)
"""D-H d_i [m], i = 1..6."""
UR16E_A: tuple[float, ...] = (0.0, -0.4784, -0.36, 0.0, 0.0, 0.0)
"""D-H a_i [m], i = 1..6."""
UR16E_ALPHA: tuple[float, ...] = (math.pi / 2, 0.0, 0.0, math.pi / 2, -math.pi / 2, 0.0)
"""D-H α_i [rad], i = 1..6."""
UR16E_MASSES: tuple[float, ...] = (7.369, 10.450, 4.321, 2.180, 2.033, 0.907)
"""Masses of links 1..6 (shoulder … wrist 3) [kg]."""
UR16E_BASE_MASS = 4.0
"""Mass of the UR16e base (link 0) as in ur_description [kg]."""
UR16E_COM: tuple[Vec3, ...] = (
    (0.0, -0.016, 0.030),
    (0.302, 0.0, 0.160),
    (0.194, 0.0, 0.065),
    (0.0, -0.009, 0.011),
    (0.0, 0.018, 0.012),
    (0.0, 0.0, -0.044),
)
"""Centres of mass of links 1..6 in their D-H frames [m]: Universal Robots' published values
("DH parameters for calculations of kinematics and dynamics"), as ur_description's
``config/ur16e/physical_parameters.yaml`` gives them (its ``center_of_mass`` entries, whose
comments map its link frames back to these D-H values)."""
UR16E_INERTIA: tuple[tuple[float, float, float, float, float, float], ...] = (
    (0.03351, 0.03374, 0.02100, 0.00002, -0.00001, 0.00374),
    (0.02796, 0.47558, 0.47635, -0.00010, -0.00720, 0.00003),
    (0.01091, 0.12060, 0.11714, 0.00006, 0.01012, 0.00001),
    (0.00609, 0.00245, 0.00579, -0.00001, 0.0, 0.00083),
    (0.00389, 0.00219, 0.00363, -0.00001, 0.0, -0.00045),
    (0.00117, 0.00118, 0.00084, 0.0, 0.0, 0.0),
)
"""Inertia tensors of links 1..6 about their centres of mass [kg·m²] as (ixx, iyy, izz, ixy,
ixz, iyz), axes parallel to the link's D-H frame: ur_description's
``config/ur16e/physical_parameters.yaml`` ``tensor`` entries. Its inertial origins rotate them by
the ``rotation`` entries (roll π/2, 0, 0, π/2, −π/2, 0), which are exactly the D-H α that turn its
link frames into the D-H frames, so the values hold in the D-H axes unchanged."""


def ur16e_inertial(i: int) -> Inertial:
    """Official inertial of UR16e link ``i`` (0-based: 0 = shoulder … 5 = wrist 3), D-H frame."""
    ixx, iyy, izz, ixy, ixz, iyz = UR16E_INERTIA[i]
    tensor = ((ixx, ixy, ixz), (ixy, iyy, iyz), (ixz, iyz, izz))
    return Inertial(UR16E_MASSES[i], UR16E_COM[i], tensor)
UR16E_VELOCITY_LIMITS: tuple[float, ...] = (
    math.radians(120.0),
    math.radians(120.0),
    math.radians(180.0),
    math.radians(180.0),
    math.radians(180.0),
    math.radians(180.0),
)
"""Joint speed limits [rad/s]: 120°/s shoulder pan and lift, 180°/s the others."""
UR16E_POSITION_LIMITS: tuple[float, ...] = (
    2 * math.pi,
    2 * math.pi,
    math.pi,
    2 * math.pi,
    2 * math.pi,
    2 * math.pi,
)
"""Symmetric joint position limits ±value [rad]: ±360°, elbow ±180° (ROS description)."""
UR16E_EFFORT_LIMITS: tuple[float, ...] = (330.0, 330.0, 150.0, 56.0, 56.0, 56.0)
"""Joint torque limits [N·m] (ur_description joint_limits.yaml of the UR16e)."""

UR_JOINTS: tuple[str, ...] = (
    "shoulder_pan_joint",
    "shoulder_lift_joint",
    "elbow_joint",
    "wrist_1_joint",
    "wrist_2_joint",
    "wrist_3_joint",
)
UR_LINKS: tuple[str, ...] = (
    "base_link",
    "shoulder_link",
    "upper_arm_link",
    "forearm_link",
    "wrist_1_link",
    "wrist_2_link",
    "wrist_3_link",
)
"""UR link names; ``UR_LINKS[i]`` carries D-H frame i."""

# Lateral offsets of the real UR16e tubes from the D-H line (along z of frames 2 and 3), used only
# for collision/visual geometry and skin placement: the shoulder offset puts the upper-arm tube at
# +0.176 along z2, the elbow offset brings the forearm tube back to about +0.04 along z3; the
# wrist-1 link then makes up the rest of d4 = 0.17415.
UPPER_ARM_TUBE_Z = 0.176
FOREARM_TUBE_Z = 0.040
UPPER_ARM_TUBE_RADIUS = 0.075
"""Outer radius of the upper arm with its skin cover [m]."""
FOREARM_TUBE_RADIUS = 0.065
"""Outer radius of the forearm with its skin cover [m]."""

SIDES: tuple[str, ...] = ("left", "right")

BASE_JOINTS: tuple[str, ...] = ("base_x", "base_y", "base_yaw")
JOINT_NAMES: tuple[str, ...] = BASE_JOINTS + tuple(
    f"{side}_{joint}" for side in SIDES for joint in UR_JOINTS
)
"""The 15 actuated (or virtual) joints in the order of the configuration vector q."""

BASE_VELOCITY_LIMITS: tuple[float, float, float] = (1.0, 1.0, 1.0)
"""Mecanum base speed limits: x [m/s], y [m/s], yaw [rad/s] (assumed hardware values)."""

# ---------------------------------------------------------------------------------------------
# Base, torso and arm mounts
# ---------------------------------------------------------------------------------------------

BASE_FOOTPRINT: tuple[float, float] = (0.80, 0.60)
"""Length (x) and width (y) of the mecanum base including its wheels [m]."""
CHASSIS_HEIGHT: tuple[float, float] = (0.10, 0.40)
"""Bottom and top of the chassis box above the floor [m]."""
WHEEL_RADIUS = 0.10
WHEEL_WIDTH = 0.10
BASE_MASS = 150.0
"""Mass of the mecanum base with batteries (assumed) [kg]."""
TORSO_SIZE: tuple[float, float, float] = (0.24, 0.30, 0.80)
"""Torso column box: depth (x), width (y), height (z) above the chassis top [m]."""
TORSO_MASS = 25.0
"""Mass of the torso column and arm brackets (assumed) [kg]."""
ARM_MOUNT_HEIGHT = 0.70
"""Height of both arm base frames above the chassis top (torso_link frame) [m]; 1.10 m above the
floor, i.e. about a standing adult's waist height, so the forearms work there."""
ARM_MOUNT_Y = 0.15
"""Lateral distance of each arm base frame from the torso's mid-plane [m] (torso half-width)."""


@dataclass(frozen=True)
class ArmMount:
    """Pose of an arm's D-H base frame (``<side>_base_link``) in ``torso_link``.

    The arms stick out sideways like a humanoid's: the shoulder-pan axis z0 points outward
    (+y left, −y right) and x0 points backward, so with q = 0 each arm is stretched forward,
    horizontally, at mount height.
    """

    side: str
    position: Vec3
    rotation: Mat3T

    def rotation_matrix(self) -> NDArray[np.float64]:
        return np.array(self.rotation, dtype=float)


def _as_mat(r: NDArray[np.float64]) -> Mat3T:
    rows = [tuple(float(v) for v in row) for row in r]
    return (rows[0], rows[1], rows[2])  # type: ignore[return-value]


ARM_MOUNTS: dict[str, ArmMount] = {
    # left: Rx(−90°)·Rz(180°) → z0 = +y, x0 = −x, y0 = +z
    "left": ArmMount(
        "left",
        (0.0, ARM_MOUNT_Y, ARM_MOUNT_HEIGHT),
        _as_mat(rot_x(-math.pi / 2) @ rot_z(math.pi)),
    ),
    # right: Rx(+90°)·Rz(180°) → z0 = −y, x0 = −x, y0 = −z
    "right": ArmMount(
        "right",
        (0.0, -ARM_MOUNT_Y, ARM_MOUNT_HEIGHT),
        _as_mat(rot_x(math.pi / 2) @ rot_z(math.pi)),
    ),
}

# ---------------------------------------------------------------------------------------------
# Generic tree data
# ---------------------------------------------------------------------------------------------

Shape = Literal["box", "cylinder", "sphere"]


@dataclass(frozen=True)
class Geom:
    """A primitive, used both as visual and as collision geometry.

    Attributes:
        name: unique geometry name (MuJoCo geom name).
        shape: ``box`` (size = half extents x, y, z), ``cylinder`` (size = radius, half length,
            along ``axis``) or ``sphere`` (size = radius,).
        size: see ``shape`` [m].
        pos: centre in the link frame [m].
        axis: cylinder axis in the link frame (unit); ignored for boxes (axis-aligned) and spheres.
        rgba: display colour.
    """

    name: str
    shape: Shape
    size: tuple[float, ...]
    pos: Vec3
    axis: Vec3 = (0.0, 0.0, 1.0)
    rgba: tuple[float, float, float, float] = (0.7, 0.7, 0.7, 1.0)

    def rotation(self) -> NDArray[np.float64]:
        """Geometry frame in the link frame (cylinders along the geometry's local z)."""
        return z_to(np.array(self.axis)) if self.shape == "cylinder" else np.eye(3)

    def volume(self) -> float:
        """Volume [m³]."""
        if self.shape == "box":
            return 8.0 * self.size[0] * self.size[1] * self.size[2]
        if self.shape == "cylinder":
            return math.pi * self.size[0] ** 2 * 2.0 * self.size[1]
        return 4.0 / 3.0 * math.pi * self.size[0] ** 3

    def inertia_about_centre(self, mass: float) -> NDArray[np.float64]:
        """Solid-body inertia tensor [kg·m²] about the centre, in the link frame."""
        if self.shape == "box":
            hx, hy, hz = (2.0 * s for s in self.size)
            local = mass / 12.0 * np.diag([hy**2 + hz**2, hx**2 + hz**2, hx**2 + hy**2])
        elif self.shape == "cylinder":
            r, length = self.size[0], 2.0 * self.size[1]
            side = mass * (3.0 * r**2 + length**2) / 12.0
            local = np.diag([side, side, 0.5 * mass * r**2])
        else:
            local = np.eye(3) * 0.4 * mass * self.size[0] ** 2
        rot = self.rotation()
        return np.asarray(rot @ local @ rot.T, dtype=float)


@dataclass(frozen=True)
class Inertial:
    """Mass [kg], centre of mass [m] and inertia about it [kg·m²], in the link frame."""

    mass: float
    com: Vec3
    inertia: Mat3T


@dataclass(frozen=True)
class Link:
    """A rigid body (or a massless frame when ``inertial`` is None and it has no geoms)."""

    name: str
    geoms: tuple[Geom, ...] = ()
    inertial: Inertial | None = None
    doc: str = ""


JointKind = Literal["revolute", "prismatic", "fixed"]


@dataclass(frozen=True)
class Joint:
    """A joint, stored the D-H way: child = parent · Motion(axis, q) · offset.

    Attributes:
        name: joint name.
        kind: ``revolute`` (rotation about ``axis`` through the parent origin), ``prismatic``
            (translation along ``axis``) or ``fixed``.
        parent, child: link names.
        axis: unit motion axis in the parent frame.
        offset_pos, offset_rot: constant transform applied after the motion [m], rotation rows.
        lower, upper: position limits [rad] or [m] (±inf = unbounded).
        velocity: speed limit [rad/s] or [m/s].
        effort: torque [N·m] or force [N] limit (0 = not applicable).
    """

    name: str
    kind: JointKind
    parent: str
    child: str
    axis: Vec3 = (0.0, 0.0, 1.0)
    offset_pos: Vec3 = (0.0, 0.0, 0.0)
    offset_rot: Mat3T = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))
    lower: float = -math.inf
    upper: float = math.inf
    velocity: float = 0.0
    effort: float = 0.0

    def offset_matrix(self) -> NDArray[np.float64]:
        return np.array(self.offset_rot, dtype=float)

    def offset_vector(self) -> NDArray[np.float64]:
        return np.array(self.offset_pos, dtype=float)


@dataclass(frozen=True)
class CylindricalPatch:
    """A skin patch on a cylindrical link surface, in its link's D-H frame.

    Surface point at axial coordinate s and angle φ (right-handed about ``axis``, φ = 0 along
    ``zero_direction``)::

        p(s, φ) = point + s·axis + radius·(cos φ·e0 + sin φ·(axis × e0)),   e0 = zero_direction

    with outward normal ``cos φ·e0 + sin φ·(axis × e0)``. The patch covers
    ``s ∈ axial_range`` and ``φ ∈ angular_range``. The cylinder is the link's collision
    cylinder (same axis line and radius), so taxels lie exactly on the collision surface.

    Attributes:
        name: patch name (skin topic / board naming): ``left_upper_arm``, ``left_forearm``,
            ``right_forearm``.
        link: link whose D-H frame the numbers are expressed in.
        axis: unit axis direction.
        point: a point on the axis, origin of s [m].
        radius: cylinder radius [m].
        axial_range: (s_min, s_max) [m].
        angular_range: (φ_min, φ_max) [rad], φ_max − φ_min ≤ 2π.
        zero_direction: unit vector ⊥ axis where φ = 0.
    """

    name: str
    link: str
    axis: Vec3
    point: Vec3
    radius: float
    axial_range: tuple[float, float]
    angular_range: tuple[float, float]
    zero_direction: Vec3

    def surface_point(self, s: float, phi: float) -> NDArray[np.float64]:
        """Point on the patch surface in the link frame [m]."""
        return np.array(self.point) + s * np.array(self.axis) + self.radius * self.normal(phi)

    def normal(self, phi: float) -> NDArray[np.float64]:
        """Outward unit surface normal at angle ``phi`` [rad], link frame."""
        a, e0 = np.array(self.axis), np.array(self.zero_direction)
        return math.cos(phi) * e0 + math.sin(phi) * np.cross(a, e0)

    def area(self) -> float:
        """Covered area [m²]."""
        return (
            self.radius
            * (self.angular_range[1] - self.angular_range[0])
            * (self.axial_range[1] - self.axial_range[0])
        )


@dataclass(frozen=True)
class RobotDescription:
    """The whole robot: links (root first), joints (tree order), skin patches."""

    name: str
    root: str
    links: tuple[Link, ...]
    joints: tuple[Joint, ...]
    patches: tuple[CylindricalPatch, ...]
    joint_names: tuple[str, ...] = field(default=JOINT_NAMES)

    def link(self, name: str) -> Link:
        for link in self.links:
            if link.name == name:
                return link
        raise KeyError(f"no link named {name!r}")

    def joint(self, name: str) -> Joint:
        for joint in self.joints:
            if joint.name == name:
                return joint
        raise KeyError(f"no joint named {name!r}")

    def patch(self, name: str) -> CylindricalPatch:
        for patch in self.patches:
            if patch.name == name:
                return patch
        raise KeyError(f"no skin patch named {name!r}")

    def children(self, link: str) -> list[Joint]:
        return [j for j in self.joints if j.parent == link]

    def position_limits(self) -> NDArray[np.float64]:
        """(15, 2) lower/upper position limits in q order [m, rad]; base unbounded (±inf)."""
        return np.array([[self.joint(n).lower, self.joint(n).upper] for n in self.joint_names])

    def velocity_limits(self) -> NDArray[np.float64]:
        """(15,) symmetric speed limits in q order [m/s, rad/s]."""
        return np.array([self.joint(n).velocity for n in self.joint_names])


# ---------------------------------------------------------------------------------------------
# Construction
# ---------------------------------------------------------------------------------------------


def _inertial(mass: float, geoms: Sequence[Geom]) -> Inertial:
    """Mass spread over the link's primitives in proportion to their volume (uniform density)."""
    volumes = np.array([g.volume() for g in geoms])
    masses = mass * volumes / volumes.sum()
    centres = np.array([g.pos for g in geoms], dtype=float)
    com = masses @ centres / mass
    inertia = np.zeros((3, 3))
    for g, m, c in zip(geoms, masses, centres, strict=True):
        d = c - com
        parallel_axis = m * (float(d @ d) * np.eye(3) - np.outer(d, d))
        inertia += g.inertia_about_centre(float(m)) + parallel_axis
    return Inertial(mass, (float(com[0]), float(com[1]), float(com[2])), _as_mat(inertia))


def _cyl(name: str, p0: Sequence[float], p1: Sequence[float], radius: float, rgba: tuple[
        float, float, float, float]) -> Geom:
    """Cylinder between the axis end points ``p0`` and ``p1`` [m]."""
    a, b = np.asarray(p0, dtype=float), np.asarray(p1, dtype=float)
    axis = (b - a) / np.linalg.norm(b - a)
    c = 0.5 * (a + b)
    return Geom(
        name,
        "cylinder",
        (radius, 0.5 * float(np.linalg.norm(b - a))),
        (float(c[0]), float(c[1]), float(c[2])),
        (float(axis[0]), float(axis[1]), float(axis[2])),
        rgba,
    )


GREY = (0.62, 0.64, 0.67, 1.0)
DARK = (0.20, 0.21, 0.23, 1.0)
BLUE = (0.16, 0.38, 0.66, 1.0)
SKIN = (0.93, 0.62, 0.32, 1.0)

UPPER_ARM_SKIN_RANGE: tuple[float, float] = (0.10, 0.38)
"""Axial range of the upper-arm skin along x2 [m]; the upper-arm tube runs x2 ∈ [0, 0.4784]."""
FOREARM_SKIN_RANGE: tuple[float, float] = (0.06, 0.30)
"""Axial range of the forearm skin along x3 [m]; the forearm tube runs x3 ∈ [0, 0.36]."""


def _arm_geoms(side: str) -> list[tuple[Geom, ...]]:
    """Primitive geometry of UR links 0..6 in their D-H frames (frame conventions in the module
    docstring). The skin-carrying tubes are single cylinders whose radius and axis line are the
    skin patches' (see :func:`skin_patches`)."""
    d1, _, _, d4, d5, d6 = UR16E_D
    a2, a3 = -UR16E_A[1], -UR16E_A[2]
    p = f"{side}_"
    tube_rgba = SKIN
    return [
        # 0: base flange, along z0
        (_cyl(p + "base", (0, 0, 0), (0, 0, 0.09), 0.085, DARK),),
        # 1: shoulder, joint-1 housing along y1 (= z0) and joint-2 housing along z1
        (
            _cyl(p + "shoulder_j1", (0, -d1 + 0.09, 0), (0, 0.06, 0), 0.080, BLUE),
            _cyl(p + "shoulder_j2", (0, 0, -0.07), (0, 0, UPPER_ARM_TUBE_Z + 0.06), 0.080, BLUE),
        ),
        # 2: upper arm tube along x2 at z2 = shoulder offset, elbow housing along z2 at x2 = 0
        (
            _cyl(p + "upper_arm_tube", (0.06, 0, UPPER_ARM_TUBE_Z),
                 (a2 - 0.08, 0, UPPER_ARM_TUBE_Z),
                 UPPER_ARM_TUBE_RADIUS, tube_rgba if side == "left" else GREY),
            _cyl(p + "elbow_j3", (0, 0, FOREARM_TUBE_Z - 0.07), (0, 0, UPPER_ARM_TUBE_Z + 0.07),
                 0.070, BLUE),
        ),
        # 3: forearm tube along x3 at z3 = forearm offset (x3 = 0 wrist end, x3 = 0.36 elbow end)
        (
            _cyl(p + "forearm_tube", (0.04, 0, FOREARM_TUBE_Z), (a3 - 0.06, 0, FOREARM_TUBE_Z),
                 FOREARM_TUBE_RADIUS, tube_rgba),
        ),
        # 4: wrist 1, joint-4 housing along y4 (= z3), from the forearm to the joint-5 housing
        (_cyl(p + "wrist_1", (0, -d4 + FOREARM_TUBE_Z - 0.03, 0), (0, 0.055, 0), 0.060, BLUE),),
        # 5: wrist 2, joint-5 housing along y5 (= −z4)
        (_cyl(p + "wrist_2", (0, d5 + 0.0, 0), (0, -0.055, 0), 0.060, BLUE),),
        # 6: wrist 3 / flange along z6
        (_cyl(p + "wrist_3", (0, 0, -d6 + 0.055), (0, 0, 0.0), 0.045, DARK),),
    ]


def skin_patches() -> tuple[CylindricalPatch, ...]:
    """The three skin patches (paper III-A: two on the left arm, one on the right), each on its
    link's collision tube, full circumference (φ ∈ [−π, π), φ = 0 along the link frame's +z)."""
    full = (-math.pi, math.pi)
    out = []
    for name, link, z, r, rng in (
        ("left_upper_arm", "left_upper_arm_link", UPPER_ARM_TUBE_Z, UPPER_ARM_TUBE_RADIUS,
         UPPER_ARM_SKIN_RANGE),
        ("left_forearm", "left_forearm_link", FOREARM_TUBE_Z, FOREARM_TUBE_RADIUS,
         FOREARM_SKIN_RANGE),
        ("right_forearm", "right_forearm_link", FOREARM_TUBE_Z, FOREARM_TUBE_RADIUS,
         FOREARM_SKIN_RANGE),
    ):
        out.append(
            CylindricalPatch(
                name=name,
                link=link,
                axis=(1.0, 0.0, 0.0),
                point=(0.0, 0.0, z),
                radius=r,
                axial_range=rng,
                angular_range=full,
                zero_direction=(0.0, 0.0, 1.0),
            )
        )
    return tuple(out)


def _dh_offset(i: int) -> tuple[Vec3, Mat3T]:
    """Tz(d_i)·Tx(a_i)·Rx(α_i) of UR joint i (0-based) as (translation, rotation)."""
    return (UR16E_A[i], 0.0, UR16E_D[i]), _as_mat(rot_x(UR16E_ALPHA[i]))


def _base_links() -> tuple[list[Link], list[Joint]]:
    length, width = BASE_FOOTPRINT
    z0, z1 = CHASSIS_HEIGHT
    wheel_y = 0.5 * width - 0.5 * WHEEL_WIDTH
    wheel_x = 0.5 * length - WHEEL_RADIUS - 0.02
    chassis = Geom(
        "chassis",
        "box",
        (0.5 * length, 0.5 * width - WHEEL_WIDTH - 0.005, 0.5 * (z1 - z0)),
        (0.0, 0.0, 0.5 * (z0 + z1)),
        rgba=GREY,
    )
    wheels = [
        _cyl(
            f"wheel_{fx}{fy}",
            (sx * wheel_x, sy * (wheel_y - 0.5 * WHEEL_WIDTH), WHEEL_RADIUS),
            (sx * wheel_x, sy * (wheel_y + 0.5 * WHEEL_WIDTH), WHEEL_RADIUS),
            WHEEL_RADIUS,
            DARK,
        )
        for fx, sx in (("front", 1.0), ("rear", -1.0))
        for fy, sy in (("_left", 1.0), ("_right", -1.0))
    ]
    base_geoms = (chassis, *wheels)
    tx, ty, tz = TORSO_SIZE
    torso_geoms = (
        Geom("torso_column", "box", (0.5 * tx, 0.5 * ty, 0.5 * tz), (0.0, 0.0, 0.5 * tz),
             rgba=GREY),
    )
    links = [
        Link("odom", doc="world / odometry frame; z up, floor at z = 0"),
        Link("base_x_link", doc="virtual: after the base's x translation"),
        Link("base_y_link", doc="virtual: after the base's y translation"),
        Link(
            "base_link",
            base_geoms,
            _inertial(BASE_MASS, base_geoms),
            doc="mecanum base: on the floor at the footprint centre, x forward, z up",
        ),
        Link(
            "torso_link",
            torso_geoms,
            _inertial(TORSO_MASS, torso_geoms),
            doc="torso column: on the chassis top, axes as base_link",
        ),
    ]
    base_v = BASE_VELOCITY_LIMITS
    joints = [
        Joint("base_x", "prismatic", "odom", "base_x_link", (1.0, 0.0, 0.0), velocity=base_v[0]),
        Joint("base_y", "prismatic", "base_x_link", "base_y_link", (0.0, 1.0, 0.0),
              velocity=base_v[1]),
        Joint("base_yaw", "revolute", "base_y_link", "base_link", (0.0, 0.0, 1.0),
              velocity=base_v[2]),
        Joint("torso_fixed", "fixed", "base_link", "torso_link", offset_pos=(0.0, 0.0, z1)),
    ]
    return links, joints


def _arm_links(side: str) -> tuple[list[Link], list[Joint]]:
    mount = ARM_MOUNTS[side]
    geoms = _arm_geoms(side)
    links: list[Link] = []
    joints: list[Joint] = []
    links.append(
        Link(f"{side}_base_link", geoms[0], _inertial(UR16E_BASE_MASS, geoms[0]),
             doc="UR D-H frame 0 (arm base)")
    )
    joints.append(
        Joint(f"{side}_arm_mount", "fixed", "torso_link", f"{side}_base_link",
              offset_pos=mount.position, offset_rot=mount.rotation)
    )
    for i in range(6):
        name = f"{side}_{UR_LINKS[i + 1]}"
        links.append(
            Link(name, geoms[i + 1], ur16e_inertial(i),
                 doc=f"UR D-H frame {i + 1}")
        )
        pos, rot = _dh_offset(i)
        limit = UR16E_POSITION_LIMITS[i]
        joints.append(
            Joint(
                f"{side}_{UR_JOINTS[i]}",
                "revolute",
                f"{side}_{UR_LINKS[i]}",
                name,
                (0.0, 0.0, 1.0),
                pos,
                rot,
                -limit,
                limit,
                UR16E_VELOCITY_LIMITS[i],
                UR16E_EFFORT_LIMITS[i],
            )
        )
    links.append(Link(f"{side}_tool0", doc="UR tool flange = D-H frame 6"))
    joints.append(Joint(f"{side}_tool0_fixed", "fixed", f"{side}_wrist_3_link", f"{side}_tool0"))
    return links, joints


@cache
def robot_description() -> RobotDescription:
    """The robot description (cached; immutable)."""
    links, joints = _base_links()
    for side in SIDES:
        arm_links, arm_joints = _arm_links(side)
        links += arm_links
        joints += arm_joints
    return RobotDescription("phri_robot", "odom", tuple(links), tuple(joints), skin_patches())


ARM_LINK_NAMES: tuple[str, ...] = tuple(f"{s}_{n}" for s in SIDES for n in UR_LINKS)
SKIN_PATCHES: tuple[str, ...] = tuple(p.name for p in skin_patches())
"""The skin patch names (``left_upper_arm``, ``left_forearm``, ``right_forearm``): the names of
their taxel topics ``skin/<patch>/taxels`` and layout files."""
SKIN_LINKS: tuple[str, ...] = tuple(p.link for p in skin_patches())
"""The links carrying skin, in patch order (``SKIN_LINKS[i]`` carries ``SKIN_PATCHES[i]``)."""
