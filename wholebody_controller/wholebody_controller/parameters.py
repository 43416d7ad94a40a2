"""Node parameters (declarative :class:`ParamSpec` lists) and their translation into
:class:`~wholebody_controller.config.ControllerConfig` (pure, no rclpy).

Per-link parameters are named ``<link>.<name>``; :func:`link_param_specs` makes them for any link
list, :data:`PARAMS` holds the full list for the default links (documented in
``docs/wholebody_controller.md``). Defaults are the paper's (:mod:`phri_common.paper`), the links
the robot description's skin links.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from phri_common import paper
from phri_common.params import ParamSpec, settings_of, values_for
from phri_common.protected import UNLOCK_PARAM
from phri_description.description import SKIN_LINKS
from wholebody_controller.config import (
    AdmittanceGains,
    ControllerConfig,
    LinkTaskConfig,
    dance_ranges,
    default_force_limits,
)
from wholebody_controller.contact_safety import SafetyConfig
from wholebody_controller.freshness import FreshnessConfig
from wholebody_controller.skin_torque_check import TorqueCheckConfig
from wholebody_controller.torque_guard import TorqueGuardConfig

LINKS_PARAM = ParamSpec(
    "links", list(SKIN_LINKS),
    "skin links with an interaction task; contact states are read from contacts/<link>",
    read_only=True, min_length=1,
)

CONTROL_LOOPS = ("auto", "thread", "timer")
"""Values of ``control_loop``; the first is the default."""


def control_loop_mode(value: str, use_sim_time: bool) -> str:
    """The control loop a node runs: ``thread`` or ``timer`` (``control_loop`` resolved).

    ``auto`` is ``timer`` under ``use_sim_time`` (a timer follows ``/clock``; the simulator's
    lock-step delivers inputs through callbacks) and ``thread`` otherwise. The thread runs on the
    wall clock, so it is refused with ``use_sim_time``.

    Raises:
        ValueError: an unknown value, or ``thread`` with ``use_sim_time`` (names the parameter).
    """
    if value not in CONTROL_LOOPS:
        raise ValueError(f"parameter 'control_loop' refused value {value!r}: allowed "
                         f"{', '.join(CONTROL_LOOPS)}")
    if value == "thread" and use_sim_time:
        raise ValueError("parameter 'control_loop' refused value 'thread' with use_sim_time: "
                         "the thread runs on the wall clock; allowed with simulation time: "
                         "timer, auto")
    if value == "auto":
        return "timer" if use_sim_time else "thread"
    return value


NODE_PARAMS: list[ParamSpec] = [
    ParamSpec("control_loop", CONTROL_LOOPS[0], "what runs the control cycle: thread (its own "
              "thread at absolute deadlines, inputs taken at each cycle), timer (an executor "
              "timer, inputs by callbacks; follows /clock), auto (timer under use_sim_time, "
              "else thread)", read_only=True),
    ParamSpec("thread_priority", 0, "control_loop thread: 0 = the normal scheduler, 1–99 = "
              "SCHED_FIFO at that priority (needs an rtprio limit or CAP_SYS_NICE; refused → "
              "warning, normal scheduler)", "-", 0, 99, read_only=True),
    ParamSpec("q_dance_enabled", False,
              "hold each arm joint within q_dance ± q_dance_range (waltz, Sec. VI-B)"),
    ParamSpec("q_dance", [0.0] * 12,
              "arm configuration q_dance, left then right arm in the command joint order",
              "rad", -7.0, 7.0, length=12),
    ParamSpec("q_dance_range", paper.Q_DANCE_HALF_WIDTH,
              "half width of the q_dance joint ranges", "rad", 0.0, 6.3),
    ParamSpec("contact_timeout", 0.1, "contact state older than this → zero command", "s",
              1e-3, 10.0, loosens="up"),
    ParamSpec("joint_state_timeout", 0.1, "joint state older than this → zero command", "s",
              1e-3, 10.0, loosens="up"),
    ParamSpec("odom_timeout", 0.1, "odometry older than this → zero command", "s", 1e-3, 10.0,
              loosens="up"),
    ParamSpec("world_frame", "odom", "frame_id of the task-state messages", read_only=True),
    ParamSpec("max_contact_force", 5000.0,
              "contact states with a larger |force| are refused as impossible", "N",
              1.0, 1e6, loosens="up"),
    ParamSpec("joint_limit_margin", 0.05,
              "joint states beyond the joint limits by more than this are refused", "rad",
              0.0, 1.0),
    ParamSpec("max_odom_jump", 0.5,
              "odometry whose position jumps farther between two messages is refused", "m",
              1e-3, 100.0),
    ParamSpec("min_speed_scaling", 0.5,
              "least UR speed scaling (teach-pendant slider × trajectory limiter, read from "
              "<arm>/speed_scaling_state_broadcaster/speed_scaling) the controller commands "
              "at: below it zero command and a warning; at or above it every joint is "
              "commanded so that all move at the smallest arm's fraction (none received: 1)",
              "-", 0.0, 1.0),
    UNLOCK_PARAM,
    ParamSpec("iso15066_override", False, "allow <link>.force_limit / transient_force_limit "
              "above the ISO/TS 15066 Table A.2 limits of the link's body region "
              "(phri_common.iso15066); the limits above the table are logged at ERROR at "
              "start-up", read_only=True),
]
"""The node's own parameters (inputs, timeouts, the control loop, the dance band)."""

GLOBAL_PARAMS: list[ParamSpec] = [
    *settings_of(ControllerConfig), *settings_of(SafetyConfig), *NODE_PARAMS,
    *settings_of(TorqueGuardConfig), *settings_of(TorqueCheckConfig)]
"""Every controller-wide parameter: the controller's and the contact safety's settings (each
declared once, as a field of :class:`ControllerConfig` / :class:`SafetyConfig`), the node's own,
then the guard's against unsensed contacts (:class:`TorqueGuardConfig`) and the skin's check
against the joints (:class:`TorqueCheckConfig`)."""

LINK_SUFFIXES: tuple[str, ...] = (
    "inertia", "damping", "stiffness", "priority_lock", "desired_force", "force_limit",
    "transient_force_limit",
)


def link_param_specs(link: str) -> list[ParamSpec]:
    """The per-link parameters ``<link>.inertia`` … for one link."""
    limit, transient = default_force_limits(link)
    return [
        ParamSpec(f"{link}.inertia", list(paper.CENTRING.inertia),
                  "admittance inertia Λ diagonal (x y z rx ry rz)",
                  "kg, kg·m²", 1e-6, 1e6, length=6),
        ParamSpec(f"{link}.damping", list(paper.CENTRING.damping),
                  "admittance damping D diagonal",
                  "N·s/m, N·m·s/rad", 0.0, 1e6, length=6),
        ParamSpec(f"{link}.stiffness", list(paper.CENTRING.stiffness),
                  "admittance stiffness K diagonal",
                  "N/m, N·m/rad", 0.0, 1e6, length=6),
        ParamSpec(f"{link}.priority_lock", 0.0,
                  "fixed priority ψ (manual task); 0 = automatic (15)", "-", 0.0, 1.0),
        ParamSpec(f"{link}.desired_force", [0.0, 0.0, 0.0],
                  "force the link exerts, base frame (waltz: 0 -10 0 on the left forearm)", "N",
                  -1000.0, 1000.0, length=3, loosens="magnitude"),
        ParamSpec(f"{link}.force_limit", limit,
                  "quasi-static contact force limit (ISO/TS 15066 region of the link): fade, "
                  "then yield; above the region's table value only with iso15066_override", "N",
                  1.0, 1e4, loosens="up"),
        ParamSpec(f"{link}.transient_force_limit", transient,
                  "transient contact force limit (reported when exceeded), ≥ force_limit; above "
                  "the region's table value only with iso15066_override", "N", 1.0, 2e4,
                  loosens="up"),
    ]


#: All parameters for the default links (the documented set).
PARAMS: list[ParamSpec] = [
    LINKS_PARAM, *GLOBAL_PARAMS, *(s for link in SKIN_LINKS for s in link_param_specs(link))
]


def _six(values: Any) -> tuple[float, float, float, float, float, float]:
    v = [float(x) for x in values]
    return (v[0], v[1], v[2], v[3], v[4], v[5])


def _link_config(values: Mapping[str, Any], link: str) -> LinkTaskConfig:
    lock = float(values[f"{link}.priority_lock"])
    force = [float(f) for f in values[f"{link}.desired_force"]]
    limit, transient = (float(values[f"{link}.{n}"])
                        for n in ("force_limit", "transient_force_limit"))
    if transient < limit:
        raise ValueError(f"parameter '{link}.transient_force_limit' = {transient} N must be ≥ "
                         f"'{link}.force_limit' = {limit} N")
    if not values.get("iso15066_override", False):
        above = above_iso_table(link, limit, transient)
        if above:
            raise ValueError(f"{above[0]} refused: above the ISO/TS 15066 table for the link's "
                             "body region; only with iso15066_override: true (read-only, set "
                             "at start-up, logged at ERROR)")
    return LinkTaskConfig(
        link=link,
        admittance=AdmittanceGains(
            inertia=_six(values[f"{link}.inertia"]),
            damping=_six(values[f"{link}.damping"]),
            stiffness=_six(values[f"{link}.stiffness"]),
        ),
        priority_lock=lock if lock > 0.0 else None,
        desired_force=(force[0], force[1], force[2]),
        force_limit=limit,
        transient_force_limit=transient,
    )


def above_iso_table(link: str, limit: float, transient: float) -> list[str]:
    """The force limits of ``link`` [N] above ISO/TS 15066's table for its body region
    (:func:`~wholebody_controller.config.default_force_limits`), as ``'parameter' = value N
    (table N)`` texts."""
    table_limit, table_transient = default_force_limits(link)
    out = []
    for name, value, table in (("force_limit", limit, table_limit),
                               ("transient_force_limit", transient, table_transient)):
        if value > table:
            out.append(f"parameter '{link}.{name}' = {value:g} N (table {table:g} N)")
    return out


def iso_overrides(values: Mapping[str, Any], links: Sequence[str]) -> list[str]:
    """What ``iso15066_override`` lets through, one text per force limit above the table (empty
    without the override): the node logs each at ERROR at start-up."""
    if not values.get("iso15066_override", False):
        return []
    return [f"{text}: above ISO/TS 15066 Table A.2 for the link's body region, allowed by the "
            "override" for link in links
            for text in above_iso_table(link, float(values[f"{link}.force_limit"]),
                                        float(values[f"{link}.transient_force_limit"]))]


def config_from_values(
    values: Mapping[str, Any], links: Sequence[str], arm_joints: Sequence[str]
) -> ControllerConfig:
    """Build the controller configuration from validated parameter values.

    Args:
        values: parameter values by name (global and per-link).
        links: the link list.
        arm_joints: the 12 arm joint names in q_dance order.

    Raises:
        ValueError: a combination is refused; the message names the parameter.
    """
    ranges = ()
    if bool(values["q_dance_enabled"]):
        ranges = dance_ranges(arm_joints, list(values["q_dance"]), float(values["q_dance_range"]))
    return ControllerConfig(
        links=tuple(_link_config(values, link) for link in links),
        joint_ranges=ranges,
        safety=SafetyConfig(**values_for(SafetyConfig, values)),
        **values_for(ControllerConfig, values),
    )


def freshness_config(values: Mapping[str, Any]) -> FreshnessConfig:
    """The input timeouts [s] from the node's parameter values."""
    return FreshnessConfig(
        contact_timeout=float(values["contact_timeout"]),
        joint_state_timeout=float(values["joint_state_timeout"]),
        odom_timeout=float(values["odom_timeout"]),
    )


def torque_guard_config(values: Mapping[str, Any]) -> TorqueGuardConfig:
    """The guard against unsensed contacts from the node's parameter values."""
    return TorqueGuardConfig(**values_for(TorqueGuardConfig, values))


def skin_check_config(values: Mapping[str, Any]) -> TorqueCheckConfig:
    """The skin's check against the joints from the node's parameter values."""
    return TorqueCheckConfig(**values_for(TorqueCheckConfig, values))
