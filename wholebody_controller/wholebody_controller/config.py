"""Controller configuration: plain frozen dataclasses (no ROS), defaults from the paper.

Defaults are Table II and Section VI of the paper, read from :mod:`phri_common.paper` (the one
place they are typed): q̇ ∈ [−0.15, 0.15] (rad/s for joints, m/s for the base translation),
k_η = 200, b = 4, K_p = 5, ψ_thr = 1e-4, ε = 0.1, h = 0.15, 100 Hz, and the desired-region margin
of 0.01 m (VI-A.2). The default admittance is the contact-centring set of VI-A.1 (Λ = 0.5 I,
D = 40 I, K = 0); the other experiments' sets are provided as constants. The skin links are the
robot description's (:data:`phri_description.description.SKIN_LINKS`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from phri_common import paper
from phri_common.iso15066 import BODY_REGIONS, region_of_link
from phri_common.paper import Vector6
from phri_common.params import check_settings, setting
from phri_description.description import SKIN_LINKS, robot_description
from wholebody_controller.contact_safety import SafetyConfig

SOLVERS: tuple[str, ...] = ("daqp", "osqp")
KERNELS: tuple[str, ...] = ("numba", "python")
"""Allowed values of ``kernel``: the control step compiled (default) or the same functions
interpreted (:mod:`~wholebody_controller.kernels`)."""

ROBOT_VELOCITY_LIMITS: tuple[float, ...] = tuple(
    math.ceil(1000.0 * v) / 1000.0 for v in robot_description().velocity_limits().tolist()
)
"""Default per-axis ``velocity_limits``: the robot description's own limits in q order [m/s,
rad/s] (base x, y, yaw, then both arms), rounded up to 1e-3 so the description's still decide."""

BASE_ACCELERATION = 1.0
"""Rated acceleration of the mecanum base's translation [m/s²]: a ≈ 220 kg platform accelerates
at roughly 0.5–1.5 m/s² (design §7); the middle of that range."""
BASE_YAW_ACCELERATION = 1.5
"""Rated yaw acceleration of the base [rad/s²]: 1 m/s² at each wheel about a centre ≈ 0.53 m
away (half wheelbase plus half track) is ≈ 1.9 rad/s²; kept below it."""
ARM_ACCELERATION = 2.0
"""Rated joint acceleration of the UR16e as the RTDE bridge drives it [rad/s²]: the ``speedJ``
acceleration of ``phri_hardware`` (``acceleration``, default 2.0), which the arm's controller
applies to every command."""
ROBOT_ACCELERATION_LIMITS: tuple[float, ...] = (
    BASE_ACCELERATION, BASE_ACCELERATION, BASE_YAW_ACCELERATION, *(ARM_ACCELERATION,) * 12)
"""Default per-axis ``acceleration_limits`` in q order [m/s², rad/s²]."""


@dataclass(frozen=True)
class AdmittanceGains:
    """Diagonals of the admittance matrices of (13), one entry per [x, y, z, rx, ry, rz].

    Attributes:
        inertia: Λ [kg] / [kg·m²], every entry > 0.
        damping: D [N·s/m] / [N·m·s/rad], ≥ 0.
        stiffness: K [N/m] / [N·m/rad], ≥ 0.
    """

    inertia: Vector6 = paper.CENTRING.inertia
    damping: Vector6 = paper.CENTRING.damping
    stiffness: Vector6 = paper.CENTRING.stiffness

    def __post_init__(self) -> None:
        for name in ("inertia", "damping", "stiffness"):
            values = getattr(self, name)
            if len(values) != 6 or not all(math.isfinite(v) for v in values):
                raise ValueError(f"admittance {name} must be 6 finite numbers, got {values!r}")
        if min(self.inertia) <= 0.0:
            raise ValueError(f"admittance inertia must be > 0, got {self.inertia!r}")
        if min(self.damping) < 0.0 or min(self.stiffness) < 0.0:
            raise ValueError("admittance damping and stiffness must be ≥ 0")

    @classmethod
    def of(cls, gains: paper.Admittance) -> AdmittanceGains:
        """The validated gains of one of the paper's sets."""
        return cls(gains.inertia, gains.damping, gains.stiffness)


#: Paper parameter sets (Sec. VI-A.1, VI-A.2, VI-A.3, VI-B).
CONTACT_CENTRING = AdmittanceGains.of(paper.CENTRING)
CONTACT_TRACKING = AdmittanceGains.of(paper.TRACKING)
WHOLE_BODY = AdmittanceGains.of(paper.WHOLE_BODY)
WALTZ = AdmittanceGains.of(paper.WALTZ)


def default_force_limits(link: str) -> tuple[float, float]:
    """(quasi-static, transient) force limits [N] of a skin link: ISO/TS 15066's for the body
    region it meets (:data:`phri_common.iso15066.SKIN_LINK_REGIONS`); a link with no mapped region
    gets the abdomen's, the lowest of the trunk and limbs (110 N / 220 N)."""
    try:
        region = region_of_link(link)
    except KeyError:
        region = BODY_REGIONS["abdomen"]
    return region.quasi_static, region.transient


@dataclass(frozen=True)
class LinkTaskConfig:
    """One skin link's interaction task.

    The automatic task (V-B, second scenario) needs only ``link`` and ``admittance``. A manual task
    (V-B, first scenario) sets any of:

    Attributes:
        link: link (frame) name as the kinematics knows it.
        admittance: Λ, D, K of (13).
        priority_lock: fixed priority ψ in (0, 1]; ``None`` = automatic (15).
        desired_force: force [N] the link is to exert on its environment, in the base frame
            (added to the wrench (12); the waltz uses 10 N to the right, i.e. (0, −10, 0)).
        reference: user reference pose of the link frame γ_i in the world, ``(R 3×3, p 3)``
            flattened as 12 numbers (row-major R, then p); ``None`` = locked at activation.
        desired_region: user desired region Ω_d in the link frame as ``(min xyz, max xyz)``
            (no margin added); ``None`` = the region at contact onset plus the margin.
        force_limit: quasi-static contact force limit F [N] (:mod:`contact_safety`); ``None`` =
            the ISO/TS 15066 limit of the body region the link meets
            (:func:`default_force_limits`).
        transient_force_limit: transient limit [N], ≥ ``force_limit``; ``None`` = the region's.
    """

    link: str
    admittance: AdmittanceGains = field(default_factory=AdmittanceGains)
    priority_lock: float | None = None
    desired_force: tuple[float, float, float] = (0.0, 0.0, 0.0)
    reference: tuple[float, ...] | None = None
    desired_region: tuple[tuple[float, float, float], tuple[float, float, float]] | None = None
    force_limit: float | None = None
    transient_force_limit: float | None = None

    def __post_init__(self) -> None:
        limit, transient = default_force_limits(self.link)
        if self.force_limit is None:
            object.__setattr__(self, "force_limit", limit)
        if self.transient_force_limit is None:
            object.__setattr__(self, "transient_force_limit",
                               max(transient, float(self.force_limit)))  # type: ignore[arg-type]
        f, t = float(self.force_limit), float(self.transient_force_limit)  # type: ignore[arg-type]
        if not (0.0 < f <= t < math.inf):
            raise ValueError(f"{self.link}: need 0 < force_limit ≤ transient_force_limit < ∞ "
                             f"[N], got {f} and {t}")
        if self.priority_lock is not None and not 0.0 < self.priority_lock <= 1.0:
            raise ValueError(
                f"{self.link}: priority_lock must be in (0, 1], got {self.priority_lock}"
            )
        if len(self.desired_force) != 3 or not all(math.isfinite(f) for f in self.desired_force):
            raise ValueError(f"{self.link}: desired_force must be 3 finite numbers")
        if self.reference is not None:
            ref = np.asarray(self.reference, dtype=float)
            if ref.shape != (12,) or not np.all(np.isfinite(ref)):
                raise ValueError(f"{self.link}: reference must be 12 finite numbers (R, p)")
            rot = ref[:9].reshape(3, 3)
            if not np.allclose(rot @ rot.T, np.eye(3), atol=1e-6) or np.linalg.det(rot) < 0:
                raise ValueError(f"{self.link}: reference rotation is not a rotation matrix")
        if self.desired_region is not None:
            lo, hi = (np.asarray(c, dtype=float) for c in self.desired_region)
            if lo.shape != (3,) or hi.shape != (3,) or not np.all(lo <= hi):
                raise ValueError(f"{self.link}: desired_region needs min ≤ max, 3 numbers each")


@dataclass(frozen=True)
class JointRange:
    """A per-task joint position range [rad] (or [m]) intersected with the joint's own limits
    (the waltz holds each arm joint within ±0.1 rad of q_dance)."""

    joint: str
    lower: float
    upper: float

    def __post_init__(self) -> None:
        if not (self.lower <= self.upper) or math.isnan(self.lower) or math.isnan(self.upper):
            raise ValueError(f"joint range of {self.joint}: need lower ≤ upper, got "
                             f"[{self.lower}, {self.upper}]")


def dance_ranges(
    joints: Sequence[str], q_dance: Sequence[float],
    half_width: float = paper.Q_DANCE_HALF_WIDTH,
) -> tuple[JointRange, ...]:
    """Ranges ``q_dance ± half_width`` [rad] (VI-B: 0.1) for the given joints."""
    if len(joints) != len(q_dance):
        raise ValueError(f"q_dance has {len(q_dance)} values for {len(joints)} joints")
    if half_width < 0.0:
        raise ValueError("q_dance half width must be ≥ 0")
    return tuple(
        JointRange(name, float(q) - half_width, float(q) + half_width)
        for name, q in zip(joints, q_dance, strict=True)
    )


@dataclass(frozen=True)
class ControllerConfig:
    """Everything the whole-body controller needs (Table II defaults).

    Attributes:
        links: the interaction tasks, one per skin link.
        k_eta: track-force gain k_η of (12) [N/m].
        b: priority shape b of (15) [s²/m²] (applied to the 6-vector norm of ẋ̃).
        k_p: task-space gain K_p of (19) [1/s].
        psi_thr: activation threshold ψ_thr, also the floor of every weight.
        epsilon: regularisation ε of (23).
        horizon: position-limit horizon h of (22) [s].
        rate_hz: control rate [Hz]; the admittance is discretised for 1/rate_hz.
        region_margin: margin added on every side of the region locked as Ω_d [m].
        region_window: onset window over which Ω_d grows to the union of the touch's regions
            [s] (0 = the paper: locked on the first frame; :mod:`region`).
        region_hysteresis: a face of Ω_i engages the track force only beyond this overshoot
            [m] (0 = the paper's (10)–(11); :mod:`region`).
        velocity_limit: |q̇| bound for every joint and base axis [rad/s] / [m/s] (Table II),
            intersected with the robot's own velocity limits.
        velocity_limits: per-axis |q̇| bounds in q order (base x, y [m/s], yaw [rad/s], then the
            arm joints [rad/s]); default :data:`ROBOT_VELOCITY_LIMITS`. The bound of axis k is
            min(robot's own, ``velocity_limit``, ``velocity_limits[k]``).
        acceleration_limits: per-axis rated accelerations in q order [m/s², rad/s²]; the QP
            keeps each command within ± this × dt of the previous one (default
            :data:`ROBOT_ACCELERATION_LIMITS`).
        joint_ranges: extra position ranges (intersected with the joint limits).
        safety: the graded force response and contact gating (:mod:`contact_safety`).
        lead_moment: every task adds the lead moment about its hold point and carries its
            reference (:mod:`~wholebody_controller.following`); off = the paper's task.
        force_deadband, torque_deadband: δ_f [N], δ_τ [N·m] of the admittance's input dead zone
            (D1, :func:`~wholebody_controller.admittance.dead_zone`); 0 = the paper's (13).
        solver: QP backend, ``"daqp"`` (exact active set, default: faster and exact) or
            ``"osqp"`` (the paper's, warm-started with tight tolerances).
        kernel: how the tasks, Jacobians and QP of a step are computed, one of
            :data:`KERNELS`: ``"numba"`` (compiled) or ``"python"`` (the same functions
            interpreted: for debugging; :mod:`~wholebody_controller.kernels`).
    """

    links: tuple[LinkTaskConfig, ...] = tuple(LinkTaskConfig(name) for name in SKIN_LINKS)
    k_eta: float = setting("k_eta", paper.K_ETA, "track-force gain k_η of (12)", "N/m",
                           0.0, 1e5)
    b: float = setting("b", paper.B, "priority shape b of (15)", "s²/m²", 0.0, 1e6)
    k_p: float = setting("k_p", paper.K_P, "task-space gain K_p of (19)", "1/s", 0.0, 1000.0)
    psi_thr: float = setting("psi_thr", paper.PSI_THR,
                             "activation threshold ψ_thr (also the weight floor)", "-",
                             1e-12, 0.5)
    epsilon: float = setting("epsilon", paper.EPSILON, "QP regularisation ε of (23)", "-",
                             1e-9, 1e6)
    horizon: float = setting("horizon", paper.HORIZON, "position-limit horizon h of (22)", "s",
                             1e-3, 10.0)
    rate_hz: float = setting("rate_hz", paper.CONTROL_RATE_HZ,
                             "control rate (timer and admittance discretisation)", "Hz",
                             1.0, 1000.0, read_only=True)
    region_margin: float = setting("region_margin", paper.REGION_MARGIN,
                                   "margin around the region locked as Ω_d", "m", 0.0, 1.0)
    region_window: float = setting(
        "region_window", 0.0, "onset window: Ω_d grows to the union of the touch's regions "
        "(+ margin) for this long (0 = paper: the first frame)", "s", 0.0, 10.0)
    region_hysteresis: float = setting(
        "region_hysteresis", 0.0, "a face of Ω_i engages the track force only beyond this "
        "overshoot, disengages inside Ω_d (0 = paper (10)–(11))", "m", 0.0, 1.0)
    velocity_limit: float = setting(
        "velocity_limit", paper.VELOCITY_LIMIT,
        "|q̇| bound of every joint and base axis (Table II), within the robot's own",
        "rad/s or m/s", 0.0, 10.0)
    velocity_limits: tuple[float, ...] = setting(
        "velocity_limits", ROBOT_VELOCITY_LIMITS, "|q̇| bound of each axis in q order (base x, "
        "y, yaw, left then right arm joints), within velocity_limit and the robot's own",
        "m/s or rad/s", 0.0, 10.0, length=15)
    acceleration_limits: tuple[float, ...] = setting(
        "acceleration_limits", ROBOT_ACCELERATION_LIMITS, "rated acceleration of each axis in q "
        "order (base x, y, yaw, left then right arm joints): each command differs from the "
        "previous one by at most this × the control period", "m/s² or rad/s²", 1e-3, 1e3,
        length=15)
    joint_ranges: tuple[JointRange, ...] = ()
    solver: str = setting("solver", "daqp",
                          "QP backend: daqp (exact, default) or osqp (warm-started)")
    kernel: str = setting("kernel", KERNELS[0], "how the tasks, Jacobians and QP of a step are "
                          "computed: numba (compiled, default) or python (the same functions "
                          "interpreted); same command to rounding")
    safety: SafetyConfig = field(default_factory=SafetyConfig)
    lead_moment: bool = setting(
        "lead_moment", False, "follow a turning lead: moment of the contact force about the "
        "contact region's middle (F1) and a leashed reference (F2, F3); false = the paper's task")
    force_deadband: float = setting(
        "force_deadband", 0.0, "dead zone of the admittance's force input (D1): a wrench force "
        "below it moves nothing, a larger one as if this much smaller (0 = the paper's (13))",
        "N", 0.0, 5.0)
    torque_deadband: float = setting(
        "torque_deadband", 0.0, "dead zone of the admittance's torque input (D1), likewise "
        "(0 = the paper's (13))", "N·m", 0.0, 0.5)
    turn_force_limit: float = setting(
        "turn_force_limit", 0.0, "contact force above which the admittance's torque input "
        "fades, to nothing at 1.5 times it (T1): a push far above the hold is no turn lead "
        "(0 = the paper's (13))", "N", 0.0, 1000.0)

    def __post_init__(self) -> None:
        check_settings(self)
        for name, allowed in (("solver", SOLVERS), ("kernel", KERNELS)):
            value = getattr(self, name)
            if value not in allowed:
                raise ValueError(f"parameter '{name}' refused value {value!r}: allowed "
                                 f"{', '.join(allowed)}")
        names = [t.link for t in self.links]
        if len(set(names)) != len(names):
            raise ValueError(f"controller config: duplicate links in {names}")

    def axis_velocity_limits(self, robot: NDArray[np.float64]) -> NDArray[np.float64]:
        """|q̇| bound of every axis [m/s, rad/s]: min(``robot`` (its own limits, q order),
        ``velocity_limit``, ``velocity_limits``).

        Raises:
            ValueError: ``velocity_limits`` does not have one entry per axis of ``robot``.
        """
        bound = np.minimum(np.asarray(robot, dtype=np.float64), self.velocity_limit)
        if len(self.velocity_limits) != bound.shape[0]:
            raise ValueError(f"controller config: velocity_limits has {len(self.velocity_limits)}"
                             f" entries, the robot {bound.shape[0]} axes (base x, y, yaw, arms)")
        return np.minimum(bound, np.asarray(self.velocity_limits, dtype=np.float64))

    @property
    def dt(self) -> float:
        """Control period [s]."""
        return 1.0 / self.rate_hz

    def link(self, name: str) -> LinkTaskConfig:
        """The task config of one link."""
        for task in self.links:
            if task.link == name:
                return task
        raise KeyError(name)


def diag6(values: Sequence[float]) -> NDArray[np.float64]:
    """6×6 diagonal matrix from 6 numbers."""
    return np.diag(np.asarray(values, dtype=np.float64))
