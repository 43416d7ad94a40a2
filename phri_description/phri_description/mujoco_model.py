"""MuJoCo model of the robot, built from :mod:`phri_description.description` with ``mujoco.MjSpec``.

One body per description link that carries geometry or mass, named as the link; one MuJoCo joint
per description joint, named as the joint. Body frames are the description's link frames (the
D-H frames for the arms): a D-H joint turns about the *parent's* z axis, so in the child body it
is a hinge whose ``pos``/``axis`` put that line where it belongs (MuJoCo, unlike URDF, allows a
joint anywhere in its body). The three virtual base joints (``base_x``, ``base_y`` slides along
odom x/y, ``base_yaw`` hinge about z) all sit in body ``base_link``; MuJoCo applies them in that
order, so ``qpos[0:3]`` = [x, y, yaw] of ``base_link`` in the world.

:func:`build_spec` returns the editable spec so the simulator can add actuators, the person,
contact settings and sensors to the same robot without a second description; :func:`build_model`
compiles it (the kinematics model the controller uses: no actuators, no contact).
"""

from __future__ import annotations

import math

import mujoco
import numpy as np

from phri_description.description import Joint, Link, RobotDescription, robot_description
from phri_description.transforms import quat_from_matrix

ROBOT_GEOM_GROUP = 2
"""Visual group of the robot's geoms (MuJoCo viewer toggles groups)."""


def _is_virtual(link: Link) -> bool:
    return not link.geoms and link.inertial is None


def _is_identity(joint: Joint) -> bool:
    return bool(
        np.allclose(joint.offset_vector(), 0.0) and np.allclose(joint.offset_matrix(), np.eye(3))
    )


def build_spec(
    description: RobotDescription | None = None,
    *,
    geoms: bool = True,
    collisions: bool = True,
) -> mujoco.MjSpec:
    """A ``MjSpec`` of the robot in an otherwise empty world.

    Args:
        description: the robot (default: :func:`robot_description`).
        geoms: add the primitive geometry (``False`` gives a lean kinematics-only model).
        collisions: geoms take part in contacts (``contype = conaffinity = 1``); otherwise they are
            visual only (0/0).

    Returns:
        The spec; joints are unactuated and unlimited-speed, position ranges are set (and
        ``limited``) for the arm joints; a keyframe ``home`` with q = 0.
    """
    desc = description or robot_description()
    spec = mujoco.MjSpec()
    spec.modelname = desc.name
    # Robot bodies carry the description's explicit inertials; bodies a user adds later without
    # one still get theirs from their geoms (MuJoCo's default "auto").
    spec.compiler.autolimits = True
    # The description is in radians; MjSpec defaults to degrees for joint ranges.
    spec.compiler.degree = False

    links = {link.name: link for link in desc.links}

    def add_link(parent_body: mujoco.MjsBody, chain: list[Joint]) -> None:
        last = chain[-1]
        link = links[last.child]
        moving = [j for j in chain if j.kind != "fixed"]
        children = desc.children(link.name)
        # Fold a massless, geometry-free virtual frame (base_x_link, base_y_link) into the next
        # body: its joints simply stack in that body.
        if (
            _is_virtual(link)
            and last.kind != "fixed"
            and _is_identity(last)
            and len(children) == 1
            and children[0].kind != "fixed"
        ):
            add_link(parent_body, [*chain, children[0]])
            return
        rot = last.offset_matrix()
        trans = last.offset_vector()
        body = parent_body.add_body()
        body.name = link.name
        body.pos = trans
        body.quat = quat_from_matrix(rot)
        if link.inertial is not None:
            body.mass = link.inertial.mass
            body.ipos = np.array(link.inertial.com)
            inertia = np.array(link.inertial.inertia)
            body.fullinertia = [
                inertia[0, 0], inertia[1, 1], inertia[2, 2],
                inertia[0, 1], inertia[0, 2], inertia[1, 2],
            ]
            body.explicitinertial = True
        # Motion about a parent-frame line, expressed in this body's frame (see module docstring).
        anchor = -rot.T @ trans
        for joint in moving:
            mj_joint = body.add_joint()
            mj_joint.name = joint.name
            mj_joint.type = (
                mujoco.mjtJoint.mjJNT_HINGE
                if joint.kind == "revolute"
                else mujoco.mjtJoint.mjJNT_SLIDE
            )
            mj_joint.axis = rot.T @ np.array(joint.axis)
            mj_joint.pos = anchor
            if math.isfinite(joint.lower) and math.isfinite(joint.upper):
                mj_joint.range = [joint.lower, joint.upper]
                mj_joint.limited = mujoco.mjtLimited.mjLIMITED_TRUE
            else:
                mj_joint.limited = mujoco.mjtLimited.mjLIMITED_FALSE
        if geoms:
            for g in link.geoms:
                mj_geom = body.add_geom()
                mj_geom.name = g.name
                mj_geom.type = {
                    "box": mujoco.mjtGeom.mjGEOM_BOX,
                    "cylinder": mujoco.mjtGeom.mjGEOM_CYLINDER,
                    "sphere": mujoco.mjtGeom.mjGEOM_SPHERE,
                }[g.shape]
                size = np.zeros(3)
                size[: len(g.size)] = g.size
                mj_geom.size = size
                mj_geom.pos = np.array(g.pos)
                mj_geom.quat = quat_from_matrix(g.rotation())
                mj_geom.rgba = np.array(g.rgba)
                mj_geom.group = ROBOT_GEOM_GROUP
                mj_geom.contype = 1 if collisions else 0
                mj_geom.conaffinity = 1 if collisions else 0
        for child in children:
            add_link(body, [child])

    for joint in desc.children(desc.root):
        add_link(spec.worldbody, [joint])

    key = spec.add_key()
    key.name = "home"
    return spec


def build_model(
    description: RobotDescription | None = None, *, geoms: bool = True, collisions: bool = True
) -> mujoco.MjModel:
    """Compile :func:`build_spec`; raises ``ValueError`` if MuJoCo rejects the model."""
    return build_spec(description, geoms=geoms, collisions=collisions).compile()


def qpos_indices(model: mujoco.MjModel, joint_names: tuple[str, ...]) -> np.ndarray:
    """``qpos`` address of each named (1-DOF) joint, in the given order."""
    return np.array(
        [model.jnt_qposadr[model.joint(name).id] for name in joint_names], dtype=np.intp
    )


def dof_indices(model: mujoco.MjModel, joint_names: tuple[str, ...]) -> np.ndarray:
    """``qvel``/Jacobian-column address of each named (1-DOF) joint, in the given order."""
    return np.array(
        [model.jnt_dofadr[model.joint(name).id] for name in joint_names], dtype=np.intp
    )
