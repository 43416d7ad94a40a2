"""Whole-body kinematics of the mecanum base + two UR16e arms (pure: no rclpy).

:class:`RobotKinematics` is the only object in the controller that touches MuJoCo state (the role
of mink's ``Configuration``): set the configuration once per control cycle with :meth:`update`,
then query link poses and Jacobians. The model is the kinematics-only MuJoCo model generated from
``phri_description`` (the one robot description), so link frames are the UR D-H frames
(paper III-A) and the contact centre offsets ᶦp_η from contact estimation are expressed in them.

Configuration q (15): ``[x, y, yaw]`` of ``base_link`` in the world (``odom``) frame [m, m, rad],
then the left arm's six joint angles, then the right arm's [rad] (order: :data:`JOINT_NAMES`).
The base coordinates are the paper's reduced base state q_b = [x y θ_yaw] (III-B); their rates
q̇_b are world-frame rates. The base itself takes a twist in its own frame: use
:func:`base_twist_from_rates` (v_base = R_z(yaw)ᵀ·[ẋ, ẏ], ω_z = yaw rate).

Jacobians are world-frame, rows [linear (3); angular (3)], columns in q order, for the rate of a
point fixed on the link and of the link's angular velocity. The point Jacobian is the paper's (8)
without the ᶦṗ_η term (the contact centre's own motion on the skin is not driven by q̇)::

    ⁰ṗ_η = [⁰ω_i]× ⁰R_i ᶦp_η + J_p,γi q̇    (8, ᶦṗ_η = 0)

Cost: docs/benchmarks.md, "Kinematics"; the hot path reuses buffers
(pass ``out=`` to the Jacobian functions to avoid even the result allocation).
"""

from __future__ import annotations

import math

import mujoco
import numpy as np
from numpy.typing import ArrayLike, NDArray

from phri_common.planar import base_to_world, world_to_base
from phri_description.description import JOINT_NAMES, RobotDescription, robot_description
from phri_description.mujoco_model import build_model, dof_indices, qpos_indices

FloatArray = NDArray[np.float64]

__all__ = ["JOINT_NAMES", "RobotKinematics", "base_rates_from_twist", "base_twist_from_rates"]


class RobotKinematics:
    """Forward kinematics and Jacobians of the robot at one configuration.

    Args:
        description: robot description (default: ``phri_description.robot_description()``); its
            joint order defines q and the Jacobian columns, its limits are reported.
        model: a MuJoCo model containing the description's bodies and joints (default: the
            kinematics-only model built from ``description``). Extra bodies/joints are allowed;
            only the description's joints are set and reported.

    Not thread-safe: one instance per thread.
    """

    def __init__(
        self, description: RobotDescription | None = None, model: mujoco.MjModel | None = None
    ) -> None:
        self.description = description or robot_description()
        self.model = model if model is not None else build_model(self.description, geoms=False)
        self.data = mujoco.MjData(self.model)
        self.joint_names: tuple[str, ...] = tuple(self.description.joint_names)
        self.nq = len(self.joint_names)
        self._qadr = qpos_indices(self.model, self.joint_names)
        self._dadr = dof_indices(self.model, self.joint_names)
        nv = self.model.nv
        # Fast path when the model's DOFs are exactly q (the default model).
        self._identity_q = self.model.nq == self.nq and bool(
            np.array_equal(self._qadr, np.arange(self.nq))
        )
        self._identity_v = nv == self.nq and bool(np.array_equal(self._dadr, np.arange(self.nq)))
        self._jac_full = np.zeros((6, nv))
        self._point = np.zeros(3)
        # MjData's arrays never move: keep views instead of re-wrapping them on every query.
        self._qpos = self.data.qpos
        self._frames: dict[str, tuple[int, FloatArray, FloatArray]] = {}
        for i in range(1, self.model.nbody):
            name = self.model.body(i).name
            if name:
                self._frames[name] = (i, self.data.xmat[i], self.data.xpos[i])
        self.link_names: tuple[str, ...] = tuple(self._frames)
        self._position_limits = self.description.position_limits()
        self._velocity_limits = self.description.velocity_limits()
        self._position_limits.flags.writeable = False
        self._velocity_limits.flags.writeable = False
        self.update(np.zeros(self.nq))

    # -- state -------------------------------------------------------------------------------

    def update(self, q: ArrayLike) -> None:
        """Set the configuration q (15) [m, m, rad, rad…] and recompute kinematics.

        Raises:
            ValueError: wrong shape or a non-finite entry (the previous state is kept).
        """
        qa = np.asarray(q, dtype=np.float64)
        if qa.shape != (self.nq,):
            raise ValueError(f"q must have shape ({self.nq},), got {qa.shape}")
        # One scalar reduction instead of an isfinite() array: NaN/inf make the dot non-finite.
        if not math.isfinite(float(np.dot(qa, qa))):
            bad = [self.joint_names[i] for i in np.flatnonzero(~np.isfinite(qa))]
            raise ValueError(f"q has non-finite values at {bad or 'huge magnitudes'}")
        if self._identity_q:
            self._qpos[:] = qa
        else:
            self._qpos[self._qadr] = qa
        mujoco.mj_kinematics(self.model, self.data)
        mujoco.mj_comPos(self.model, self.data)  # mj_jac needs cdof and subtree_com

    @property
    def dofs_are_q(self) -> bool:
        """Whether the model's positions and DOFs are exactly q, in order (the default model):
        MuJoCo's arrays then are q-indexed (the compiled step, :mod:`fused`, needs it)."""
        return self._identity_q and self._identity_v

    @property
    def q(self) -> FloatArray:
        """A copy of the configuration last passed to :meth:`update`."""
        return np.array(self._qpos[self._qadr])

    # -- limits ------------------------------------------------------------------------------

    @property
    def position_limits(self) -> FloatArray:
        """(15, 2) [lower, upper] position limits in q order [m, rad]; base x/y/yaw are ±inf."""
        return self._position_limits

    @property
    def velocity_limits(self) -> FloatArray:
        """(15,) symmetric speed limits in q order [m/s, rad/s] (hardware limits)."""
        return self._velocity_limits

    # -- queries -----------------------------------------------------------------------------

    def _frame(self, link: str) -> tuple[int, FloatArray, FloatArray]:
        try:
            return self._frames[link]
        except KeyError:
            raise KeyError(f"unknown link {link!r}; known: {', '.join(self.link_names)}") from None

    def body_id(self, link: str) -> int:
        """MuJoCo body id of a link; ``KeyError`` naming the known links if unknown."""
        return self._frame(link)[0]

    def link_pose(self, link: str) -> tuple[FloatArray, FloatArray]:
        """World pose of the link frame: (⁰R_i (3×3), ⁰p_γi (3) [m]); copies."""
        _, xmat, xpos = self._frame(link)
        return xmat.reshape(3, 3).copy(), xpos.copy()

    def link_pose_floats(self, link: str) -> tuple[list[float], list[float]]:
        """:meth:`link_pose` as plain floats (⁰R_i row-major 9, ⁰p_γi 3 [m]) for the control
        step, which works on floats: no copies or reshapes on the way."""
        _, xmat, xpos = self._frame(link)
        return xmat.tolist(), xpos.tolist()

    def point_position(self, link: str, point_in_link: ArrayLike) -> FloatArray:
        """World position of a point fixed on the link, eq. (6): ⁰R_i ᶦp + ⁰p_γi [m]."""
        _, xmat, xpos = self._frame(link)
        p = np.asarray(point_in_link, dtype=np.float64)
        return xmat.reshape(3, 3) @ p + xpos

    def point_jacobian(
        self, link: str, point_in_link: ArrayLike, out: FloatArray | None = None
    ) -> FloatArray:
        """6×15 world-frame Jacobian [linear; angular] of a point fixed on ``link``.

        Args:
            link: link (D-H frame) name.
            point_in_link: ᶦp_η, the point in the link frame [m].
            out: optional (6, 15) float64 C-contiguous array to write into (no allocation).

        Returns:
            J with ``J @ q̇`` = [⁰ṗ (m/s); ⁰ω (rad/s)] (eq. 8 with ᶦṗ_η = 0).
        """
        body, xmat, xpos = self._frame(link)
        p = np.asarray(point_in_link, dtype=np.float64)
        if p.shape != (3,):
            raise ValueError(f"point_in_link must have shape (3,), got {p.shape}")
        # eq. (6) in C: the numpy equivalent costs several times more at this size
        mujoco.mju_mulMatVec3(self._point, xmat, p)
        mujoco.mju_addTo3(self._point, xpos)
        return self._jacobian(body, self._point, out)

    def frame_jacobian(self, link: str, out: FloatArray | None = None) -> FloatArray:
        """6×15 world-frame Jacobian [linear; angular] of the link frame's origin ⁰p_γi."""
        body, _, xpos = self._frame(link)
        return self._jacobian(body, xpos, out)

    def _jacobian(self, body: int, point: FloatArray, out: FloatArray | None) -> FloatArray:
        if out is None:
            out = np.empty((6, self.nq))
        elif out.shape != (6, self.nq) or out.dtype != np.float64:
            raise ValueError(f"out must be a float64 array of shape (6, {self.nq})")
        if self._identity_v and out.flags.c_contiguous:
            mujoco.mj_jac(self.model, self.data, out[:3], out[3:], point, body)
        else:
            full = self._jac_full
            mujoco.mj_jac(self.model, self.data, full[:3], full[3:], point, body)
            np.take(full, self._dadr, axis=1, out=out)
        return out


def base_twist_from_rates(yaw: float, rates: ArrayLike) -> FloatArray:
    """Base-frame twist [v_x, v_y (m/s), ω_z (rad/s)] from world-frame rates [ẋ, ẏ, ψ̇] of q_b.

    v = R_z(yaw)ᵀ [ẋ, ẏ]; ω_z = ψ̇ (the base moves in the plane, so its yaw rate is frame-free).
    """
    r = np.asarray(rates, dtype=np.float64)
    return np.array([*world_to_base(yaw, float(r[0]), float(r[1])), r[2]])


def base_rates_from_twist(yaw: float, twist: ArrayLike) -> FloatArray:
    """Inverse of :func:`base_twist_from_rates`: world rates [ẋ, ẏ, ψ̇] from a base twist."""
    t = np.asarray(twist, dtype=np.float64)
    return np.array([*base_to_world(yaw, float(t[0]), float(t[1])), t[2]])
