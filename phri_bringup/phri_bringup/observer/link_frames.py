"""Link frames of the robot from joint states and odometry (pure: MuJoCo, no rclpy).

The recorder writes them as ``/tf`` (moving joints) and ``/tf_static`` (fixed joints, once,
latched) as robot_state_publisher does, and the Foxglove bridge streams them, so a recording or a
live view shows the robot without a ROS robot state publisher. The tree is exactly the URDF's
(phri_description.urdf_writer.urdf_transforms: the same parents, helper ``*_motion`` links and
base joints ``odom → base_x_link → base_y_link → base_link`` robot_state_publisher publishes), so
a recording replayed beside robot_state_publisher gives no link two parents.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from functools import cache

import mujoco
import numpy as np
from numpy.typing import NDArray

from phri_description.description import BASE_JOINTS

FloatArray = NDArray[np.float64]

WORLD_FRAME = "odom"
"""Name of MuJoCo's world body as a TF frame."""


@dataclass(frozen=True)
class Transform:
    """Child frame in its parent: translation [m], rotation quaternion (w, x, y, z)."""

    parent: str
    child: str
    translation: tuple[float, float, float]
    rotation: tuple[float, float, float, float]


@cache
def fixed_joint_edges() -> frozenset[tuple[str, str]]:
    """(parent, child) link pairs of the URDF's fixed joints: robot_state_publisher sends them
    on ``/tf_static``, every other joint on ``/tf``."""
    import xml.etree.ElementTree as ET

    from phri_description.urdf_writer import urdf_string

    edges = set()
    for joint in ET.fromstring(urdf_string()).iter("joint"):
        parent, child = joint.find("parent"), joint.find("child")
        if joint.get("type") == "fixed" and parent is not None and child is not None:
            edges.add((str(parent.get("link")), str(child.get("link"))))
    return frozenset(edges)


def split_static(transforms: Sequence[Transform]) -> tuple[list[Transform], list[Transform]]:
    """(moving, fixed) transforms: the fixed joints' go on ``/tf_static``, the rest on ``/tf``."""
    fixed = fixed_joint_edges()
    moving = [t for t in transforms if (t.parent, t.child) not in fixed]
    static = [t for t in transforms if (t.parent, t.child) in fixed]
    return moving, static


class RobotFrames:
    """Forward kinematics of every robot link (parent-relative transforms, the TF tree)."""

    def __init__(self) -> None:
        from phri_sim.world.scene import robot_spec

        self.model = robot_spec().compile()
        self.data = mujoco.MjData(self.model)
        m = self.model
        self.joint_qpos = {m.joint(j).name: int(m.jnt_qposadr[j]) for j in range(m.njnt)}
        self.names = [WORLD_FRAME if b == 0 else m.body(b).name for b in range(m.nbody)]
        self.parents = [int(m.body_parentid[b]) for b in range(m.nbody)]

    def set_state(self, joint_names: Sequence[str], positions: Sequence[float],
                  base: Sequence[float] | None = None) -> None:
        """Set joint positions by name [rad] and the base pose (x [m], y [m], yaw [rad]).
        Unknown names are ignored (a joint state may carry other joints)."""
        for name, value in zip(joint_names, positions, strict=False):
            adr = self.joint_qpos.get(name)
            if adr is not None and np.isfinite(value):
                self.data.qpos[adr] = float(value)
        if base is not None:
            for name, value in zip(BASE_JOINTS, base, strict=True):
                if np.isfinite(value):
                    self.data.qpos[self.joint_qpos[name]] = float(value)

    def transforms(self) -> list[Transform]:
        """Every URDF joint's child in its parent frame at the current state (parents first)."""
        from phri_description.urdf_writer import urdf_transforms

        mujoco.mj_kinematics(self.model, self.data)
        positions = {name: float(self.data.qpos[adr]) for name, adr in self.joint_qpos.items()}
        out = []
        quat = np.zeros(4)
        for parent, child, rot, pos in urdf_transforms(positions):
            mujoco.mju_mat2Quat(quat, np.ascontiguousarray(rot).reshape(9))
            out.append(Transform(parent, child, (float(pos[0]), float(pos[1]), float(pos[2])),
                                 (float(quat[0]), float(quat[1]), float(quat[2]),
                                  float(quat[3]))))
        return out

