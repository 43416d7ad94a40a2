"""URDF writer for the robot description (robot_state_publisher, rviz, Foxglove).

The description stores joints the D-H way (child = parent · Motion(axis, q) · offset), URDF the
other way round (child = parent · origin · Motion(axis, q)). To keep every link frame of the URDF
exactly the description's (D-H) frame, a moving joint with a non-identity offset becomes two URDF
joints: the moving joint into a massless helper link ``<child>_motion`` and a fixed joint
``<joint>_offset`` carrying the offset into the child. TF therefore holds every D-H frame the
skins, contacts and controller use.

The skin patches (cylindrical specs in their link's D-H frame) are listed in the URDF's header
comment and written as ``config/skin_patches.yaml`` (installed to ``share/phri_description/config``)
for consumers that do not import Python.

Regenerate the checked-in files with ``python -m phri_description.urdf_writer``.
"""

from __future__ import annotations

import math
import sys
from collections.abc import Mapping
from functools import cache
from pathlib import Path
from xml.sax.saxutils import quoteattr

import numpy as np
import yaml

from phri_common.share import share_file, source_tree
from phri_description.description import (
    CylindricalPatch,
    Geom,
    Joint,
    Link,
    RobotDescription,
    robot_description,
)
from phri_description.transforms import axis_angle, rpy_from_matrix

PACKAGE = "phri_description"
URDF_FILE = "urdf/phri_robot.urdf"
"""The URDF, relative to the package's share directory (and its source tree)."""
PATCHES_FILE = "config/skin_patches.yaml"
"""The skin patch specs, relative to the package's share directory (and its source tree)."""


def urdf_path() -> Path:
    """The installed URDF (``share/phri_description/urdf/``; the source tree on the pip path)."""
    return share_file(PACKAGE, URDF_FILE)


def patches_path() -> Path:
    """The installed skin patch YAML (``share/phri_description/config/``)."""
    return share_file(PACKAGE, PATCHES_FILE)


def source_dir() -> Path:
    """This package's source tree, where :func:`main` writes the checked-in files.

    Raises:
        FileNotFoundError: the module does not run from a source checkout (an installed copy).
    """
    found = source_tree(PACKAGE)
    if found is None:
        raise FileNotFoundError("regenerate the description from a source checkout: "
                                f"{PACKAGE} is imported from an installed copy ({__file__})")
    return found


RESOLUTION = 1e-9
"""Smallest magnitude the generated files write [m, rad, kg, kg·m²]: anything smaller is 0."""


def _f(x: float) -> str:
    """``x`` as written to the URDF: 9 significant digits, and 0 below :data:`RESOLUTION`.

    The description's numbers come from trigonometry and matrix products whose last bits differ
    between machines and numpy/BLAS builds (a centre of mass of ``9.97e-20`` on one, ``0`` on
    another); a zero must be written as one everywhere. ``+ 0.0`` turns −0 into 0.
    """
    return f"{(0.0 if abs(x) < RESOLUTION else x) + 0.0:.9g}"


def _origin(xyz: np.ndarray | tuple[float, ...], rot: np.ndarray) -> str:
    rpy = rpy_from_matrix(np.asarray(rot, dtype=float))
    return (
        f'<origin xyz="{" ".join(_f(float(v)) for v in xyz)}" '
        f'rpy="{" ".join(_f(float(v)) for v in rpy)}"/>'
    )


def _geometry(geom: Geom) -> str:
    if geom.shape == "box":
        size = " ".join(_f(2.0 * v) for v in geom.size)
        return f'<geometry><box size="{size}"/></geometry>'
    if geom.shape == "cylinder":
        return (
            f'<geometry><cylinder radius="{_f(geom.size[0])}" '
            f'length="{_f(2.0 * geom.size[1])}"/></geometry>'
        )
    return f'<geometry><sphere radius="{_f(geom.size[0])}"/></geometry>'


def _link(link: Link) -> list[str]:
    out = [f"  <link name={quoteattr(link.name)}>"]
    if link.inertial is not None:
        inertia = np.asarray(link.inertial.inertia, dtype=float)
        out += [
            "    <inertial>",
            f"      {_origin(link.inertial.com, np.eye(3))}",
            f'      <mass value="{_f(link.inertial.mass)}"/>',
            f'      <inertia ixx="{_f(inertia[0, 0])}" ixy="{_f(inertia[0, 1])}" '
            f'ixz="{_f(inertia[0, 2])}" iyy="{_f(inertia[1, 1])}" iyz="{_f(inertia[1, 2])}" '
            f'izz="{_f(inertia[2, 2])}"/>',
            "    </inertial>",
        ]
    for geom in link.geoms:
        origin = _origin(geom.pos, geom.rotation())
        rgba = " ".join(_f(v) for v in geom.rgba)
        out += [
            f"    <visual name={quoteattr(geom.name)}>",
            f"      {origin}",
            f"      {_geometry(geom)}",
            f'      <material name={quoteattr(geom.name + "_material")}>'
            f'<color rgba="{rgba}"/></material>',
            "    </visual>",
            f"    <collision name={quoteattr(geom.name)}>",
            f"      {origin}",
            f"      {_geometry(geom)}",
            "    </collision>",
        ]
    out.append("  </link>")
    return out


def _limit(joint: Joint) -> str:
    lower = joint.lower if math.isfinite(joint.lower) else -1e6
    upper = joint.upper if math.isfinite(joint.upper) else 1e6
    return (
        f'<limit lower="{_f(lower)}" upper="{_f(upper)}" effort="{_f(joint.effort)}" '
        f'velocity="{_f(joint.velocity)}"/>'
    )


@cache
def _needs_helper(joint: Joint) -> bool:
    """A moving joint with a non-identity offset becomes two URDF joints (module docstring);
    cached: a joint is an immutable value and /tf asks for every joint 50 times a second."""
    return joint.kind != "fixed" and not (
        np.allclose(joint.offset_matrix(), np.eye(3)) and not np.any(joint.offset_vector()))


def urdf_transforms(positions: Mapping[str, float], description: RobotDescription | None = None
                    ) -> list[tuple[str, str, np.ndarray, np.ndarray]]:
    """Every URDF joint's transform at joint ``positions`` [rad or m, by name; absent = 0]:
    (parent, child, rotation 3×3, translation [m]) of the child frame in the parent frame, in
    description order (parents first) — what robot_state_publisher puts on /tf and /tf_static
    for the URDF of :func:`urdf_string`: a moving joint is Motion(axis, q) (rotation about
    ``axis`` or translation along it), its ``_offset`` joint or a fixed joint the offset."""
    desc = description or robot_description()
    out = []
    for joint in desc.joints:
        offset = (joint.parent, joint.child, joint.offset_matrix(), joint.offset_vector())
        if joint.kind == "fixed":
            out.append(offset)
            continue
        q = float(positions.get(joint.name, 0.0))
        axis = np.asarray(joint.axis, dtype=float)
        motion_child = f"{joint.child}_motion" if _needs_helper(joint) else joint.child
        if joint.kind == "prismatic":
            out.append((joint.parent, motion_child, np.eye(3), axis * q))
        else:
            out.append((joint.parent, motion_child, axis_angle(axis, q), np.zeros(3)))
        if _needs_helper(joint):
            out.append((motion_child, *offset[1:]))
    return out


def _joint(joint: Joint) -> tuple[list[str], list[str]]:
    """URDF joint elements and helper link names for one description joint."""
    offset_rot = joint.offset_matrix()
    offset_pos = joint.offset_vector()
    if joint.kind == "fixed":
        return [
            f'  <joint name={quoteattr(joint.name)} type="fixed">',
            f"    <parent link={quoteattr(joint.parent)}/>",
            f"    <child link={quoteattr(joint.child)}/>",
            f"    {_origin(offset_pos, offset_rot)}",
            "  </joint>",
        ], []
    identity_offset = not _needs_helper(joint)
    moving_child = joint.child if identity_offset else f"{joint.child}_motion"
    kind = "prismatic" if joint.kind == "prismatic" else "revolute"
    if kind == "revolute" and not (math.isfinite(joint.lower) and math.isfinite(joint.upper)):
        kind = "continuous"
    out = [
        f'  <joint name={quoteattr(joint.name)} type="{kind}">',
        f"    <parent link={quoteattr(joint.parent)}/>",
        f"    <child link={quoteattr(moving_child)}/>",
        f"    {_origin((0.0, 0.0, 0.0), np.eye(3))}",
        f'    <axis xyz="{" ".join(_f(v) for v in joint.axis)}"/>',
        f"    {_limit(joint)}",
        "  </joint>",
    ]
    if identity_offset:
        return out, []
    out += [
        f'  <joint name={quoteattr(joint.name + "_offset")} type="fixed">',
        f"    <parent link={quoteattr(moving_child)}/>",
        f"    <child link={quoteattr(joint.child)}/>",
        f"    {_origin(offset_pos, offset_rot)}",
        "  </joint>",
    ]
    return out, [moving_child]


def urdf_string(description: RobotDescription | None = None) -> str:
    """The robot as a URDF document (link frames = the description's D-H frames)."""
    desc = description or robot_description()
    lines = [
        '<?xml version="1.0"?>',
        "<!-- Generated by phri_description.urdf from phri_description.description: do not edit."
        " Regenerate with: python -m phri_description.urdf_writer -->",
        "<!-- Skin patches: cylinders in their link's D-H frame [m, rad];"
        " p(s, phi) = point + s*axis + radius*(cos(phi)*e0 + sin(phi)*(axis x e0)),"
        " e0 = zero_direction (see config/skin_patches.yaml)",
        *(_patch_comment(p) for p in desc.patches),
        "-->",
        f"<robot name={quoteattr(desc.name)}>",
    ]
    joint_lines: list[str] = []
    helpers: list[str] = []
    for joint in desc.joints:
        elements, extra = _joint(joint)
        joint_lines += elements
        helpers += extra
    for link in desc.links:
        lines += _link(link)
    for name in helpers:
        lines.append(f"  <link name={quoteattr(name)}/>")
    lines += joint_lines
    lines.append("</robot>")
    return "\n".join(lines) + "\n"


def _patch_comment(p: CylindricalPatch) -> str:
    def v(values: tuple[float, ...]) -> str:
        return " ".join(_f(x) for x in values)

    return (
        f"     {p.name}: link {p.link}, axis ({v(p.axis)}), point ({v(p.point)}), "
        f"radius {_f(p.radius)}, s in [{v(p.axial_range)}], phi in [{v(p.angular_range)}], "
        f"e0 ({v(p.zero_direction)})"
    )


def patches_yaml(description: RobotDescription | None = None) -> str:
    """``config/skin_patches.yaml``: the skin patches as plain data (deterministic text)."""
    desc = description or robot_description()
    data = {
        "units": {"length": "m", "angle": "rad"},
        "convention": (
            "numbers in each patch's link frame (UR D-H frame); "
            "p(s, phi) = point + s*axis + radius*(cos(phi)*e0 + sin(phi)*(axis x e0)), "
            "e0 = zero_direction, outward normal = cos(phi)*e0 + sin(phi)*(axis x e0)"
        ),
        "patches": [
            {
                "name": p.name,
                "link": p.link,
                "axis": [float(x) for x in p.axis],
                "point": [float(x) for x in p.point],
                "radius": float(p.radius),
                "axial_range": [float(x) for x in p.axial_range],
                "angular_range": [float(x) for x in p.angular_range],
                "zero_direction": [float(x) for x in p.zero_direction],
            }
            for p in desc.patches
        ],
    }
    header = (
        "# Generated by phri_description.urdf_writer from phri_description.description:"
        " do not edit.\n"
    )
    return header + yaml.safe_dump(data, sort_keys=False, width=100)


def load_patches_yaml(text: str) -> list[CylindricalPatch]:
    """Parse :func:`patches_yaml` text back into :class:`CylindricalPatch` objects."""
    out = []
    for p in yaml.safe_load(text)["patches"]:
        def vec(key: str, entry: dict[str, object] = p) -> tuple[float, float, float]:
            x, y, z = (float(v) for v in entry[key])  # type: ignore[attr-defined]
            return (x, y, z)

        out.append(
            CylindricalPatch(
                name=str(p["name"]),
                link=str(p["link"]),
                axis=vec("axis"),
                point=vec("point"),
                radius=float(p["radius"]),
                axial_range=(float(p["axial_range"][0]), float(p["axial_range"][1])),
                angular_range=(float(p["angular_range"][0]), float(p["angular_range"][1])),
                zero_direction=vec("zero_direction"),
            )
        )
    return out


def main() -> None:
    """Write the checked-in URDF and patch YAML into the source tree (or only the URDF, to the
    path given as the only argument)."""
    if len(sys.argv) > 1:
        targets = [(Path(sys.argv[1]), urdf_string())]
    else:
        root = source_dir()
        targets = [(root / URDF_FILE, urdf_string()), (root / PATCHES_FILE, patches_yaml())]
    for path, text in targets:
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text, encoding="utf-8")
        print(f"wrote {path}")


if __name__ == "__main__":
    main()
