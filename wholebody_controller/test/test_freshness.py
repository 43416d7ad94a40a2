"""Input freshness rules F1–F8 (``wholebody_controller.freshness``), one test per rule.

Timeouts are distinct powers of two (contacts 1/8 s, joints 1/4 s, odometry 3/8 s) and the clock
starts at 2 s, so every age is exact in binary floating point: a boundary age equals its timeout
exactly, and a rule that used another input's timeout would give another verdict.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import pytest

from wholebody_controller import freshness as freshness_module
from wholebody_controller.freshness import (
    NEVER,
    REASONS,
    STALE_CONTACTS,
    STALE_JOINTS,
    STALE_ODOMETRY,
    FreshnessConfig,
    InputFreshness,
)

DOC = Path(__file__).resolve().parents[2] / "docs" / "wholebody_controller.md"

LINKS = ("right_forearm_link", "left_upper_arm_link", "left_forearm_link")  # not sorted
LEFT = tuple(f"left_j{i}" for i in range(6))
RIGHT = tuple(f"right_j{i}" for i in range(6))
JOINTS = LEFT + RIGHT
CONFIG = FreshnessConfig(contact_timeout=0.125, joint_state_timeout=0.25, odom_timeout=0.375)
T0 = 2.0


def make() -> InputFreshness:
    return InputFreshness(LINKS, JOINTS, CONFIG)


def all_arrive(f: InputFreshness, now: float) -> None:
    for link in LINKS:
        f.contact_arrived(link, now)
    f.joints_arrived(set(JOINTS) | {"base_x", "wheel_fl"}, now)
    f.odom_arrived(now)


def fresh_at(now: float) -> InputFreshness:
    f = make()
    all_arrive(f, now)
    return f


def contacts_reason(*links: str) -> str:
    return f"{STALE_CONTACTS}: {', '.join(links)}"


# -- F1 contact timeout -------------------------------------------------------------------------
def test_f1_contact_state_older_than_contact_timeout_is_stale() -> None:
    f = fresh_at(T0)
    assert f.stale_reason(T0 + 0.125) is None, "an age equal to the timeout is fresh"
    # Past the contact timeout but within the joint and odometry ones: only contacts are stale.
    assert f.stale_reason(T0 + 0.126) == contacts_reason(*LINKS)
    for link in LINKS:
        f.contact_arrived(link, T0 + 0.126)
    assert f.stale_reason(T0 + 0.126) is None


def test_f1_every_link_is_checked_and_named() -> None:
    for old in LINKS:
        f = fresh_at(T0)
        for link in LINKS:
            if link != old:
                f.contact_arrived(link, T0 + 0.1)
        assert f.stale_reason(T0 + 0.2) == contacts_reason(old)


# -- F2 joint timeout, oldest joint, partial coverage --------------------------------------------
def test_f2_joint_state_older_than_joint_state_timeout_is_stale() -> None:
    f = fresh_at(T0)
    later = T0 + 0.25
    for link in LINKS:
        f.contact_arrived(link, later)
    f.odom_arrived(later)
    assert f.stale_reason(later) is None, "an age equal to the timeout is fresh"
    now = T0 + 0.26
    for link in LINKS:
        f.contact_arrived(link, now)
    f.odom_arrived(now)
    assert f.stale_reason(now) == STALE_JOINTS
    f.joints_arrived(JOINTS, now)
    assert f.stale_reason(now) is None


@pytest.mark.parametrize("part", [LEFT, RIGHT, JOINTS[:1], JOINTS[-1:]])
def test_f2_partial_joint_coverage_lets_the_others_age(part: tuple[str, ...]) -> None:
    f = fresh_at(T0)
    now = T0 + 0.3  # past the joint timeout for the joints the messages stop naming
    for t in (T0 + 0.1, T0 + 0.2, now):
        for link in LINKS:
            f.contact_arrived(link, t)
        f.odom_arrived(t)
        f.joints_arrived(part, t)  # only some joints keep coming
    assert f.stale_reason(now) == STALE_JOINTS
    f.joints_arrived(set(JOINTS) - set(part), now)
    assert f.stale_reason(now) is None


def test_f2_untracked_joint_names_do_not_refresh() -> None:
    f = fresh_at(T0)
    now = T0 + 0.3
    for link in LINKS:
        f.contact_arrived(link, now)
    f.odom_arrived(now)
    f.joints_arrived({"base_x", "base_y", "left_j0_mimic"}, now)
    assert f.stale_reason(now) == STALE_JOINTS
    assert f.joint_time == (T0,) * 12


# -- F3 odometry timeout -------------------------------------------------------------------------
def test_f3_odometry_older_than_odom_timeout_is_stale() -> None:
    f = fresh_at(T0)
    for now, expected in ((T0 + 0.375, None), (T0 + 0.376, STALE_ODOMETRY)):
        for link in LINKS:
            f.contact_arrived(link, now)
        f.joints_arrived(JOINTS, now)
        assert f.stale_reason(now) == expected, now
    f.odom_arrived(T0 + 0.376)
    assert f.stale_reason(T0 + 0.376) is None


# -- F4 never received, F6 reason order ----------------------------------------------------------
def test_f4_inputs_never_received_are_stale_and_f6_reasons_come_in_order() -> None:
    f = make()
    assert f.stale_reason(T0) == contacts_reason(*LINKS), "links named in the order of links"
    for link in reversed(LINKS[1:]):  # arrival order must not change the naming order
        f.contact_arrived(link, T0)
    assert f.stale_reason(T0) == contacts_reason(LINKS[0])
    f.contact_arrived(LINKS[0], T0)
    assert f.stale_reason(T0) == STALE_JOINTS
    f.joints_arrived(JOINTS[:-1], T0)  # one joint never reported
    assert f.stale_reason(T0) == STALE_JOINTS
    f.joints_arrived(JOINTS[-1:], T0)
    assert f.stale_reason(T0) == STALE_ODOMETRY
    f.odom_arrived(T0)
    assert f.stale_reason(T0) is None


def test_f6_contacts_are_reported_before_joints_before_odometry() -> None:
    f = fresh_at(T0)
    assert f.stale_reason(T0 + 10.0) == contacts_reason(*LINKS)
    for link in LINKS:
        f.contact_arrived(link, T0 + 10.0)
    assert f.stale_reason(T0 + 10.0) == STALE_JOINTS


def test_f4_never_is_minus_infinity_and_all_joints_received_needs_every_joint() -> None:
    f = make()
    assert f.odom_time == NEVER == -math.inf and set(f.contact_time.values()) == {NEVER}
    assert not f.all_joints_received()
    f.joints_arrived(LEFT, T0)
    assert not f.all_joints_received(), "the right arm was never reported"
    f.joints_arrived(RIGHT, T0)
    assert f.all_joints_received()
    assert f.all_joints_received(), "however long ago"


# -- F5 clock jumped back ------------------------------------------------------------------------
def test_f5_contact_state_from_the_future_is_stale_until_it_arrives_again() -> None:
    f = fresh_at(T0)
    back = T0 - 0.5  # e.g. a simulation reset
    f.joints_arrived(JOINTS, back)
    f.odom_arrived(back)
    assert f.stale_reason(back) == contacts_reason(*LINKS)
    for link in LINKS:
        f.contact_arrived(link, back)
    assert f.stale_reason(back) is None


def test_f5_odometry_from_the_future_is_stale() -> None:
    f = fresh_at(T0)
    back = T0 - 0.5
    for link in LINKS:
        f.contact_arrived(link, back)
    f.joints_arrived(JOINTS, back)
    assert f.stale_reason(back) == STALE_ODOMETRY
    f.odom_arrived(back)
    assert f.stale_reason(back) is None


def test_f5_joints_from_the_future_are_stale_even_when_the_oldest_is_fresh() -> None:
    f = fresh_at(T0)
    back = T0 - 0.5
    for link in LINKS:
        f.contact_arrived(link, back)
    f.odom_arrived(back)
    assert f.stale_reason(back) == STALE_JOINTS, "every joint from the other timeline"
    # Only the left arm reports after the jump: its joints are the oldest and fresh, the right
    # arm's positions are from the other timeline.
    f.joints_arrived(LEFT, back)
    assert min(f.joint_time) == back
    assert f.stale_reason(back) == STALE_JOINTS
    f.joints_arrived(RIGHT, back)
    assert f.stale_reason(back) is None


# -- F7 reset on becoming stale, F8 recovery -----------------------------------------------------
def test_f7_became_stale_once_per_fresh_to_stale_transition_f8_recovery() -> None:
    f = make()
    start = [f.check(T0 + 0.01 * k) for k in range(3)]
    assert all(v.reason is not None and not v.became_stale for v in start), "not at start-up"
    all_arrive(f, T0)
    first = f.check(T0)
    assert first.reason is None and not first.became_stale  # F8: first fresh cycle is fresh
    verdicts = [f.check(T0 + 0.125 + 0.01 * k) for k in range(4)]  # 0.125 still fresh
    assert [v.became_stale for v in verdicts] == [False, True, False, False]
    assert [v.reason is None for v in verdicts] == [True, False, False, False]
    all_arrive(f, T0 + 1.0)
    assert f.check(T0 + 1.0) == freshness_module.Verdict(None, False)
    again = f.check(T0 + 2.0)
    assert again.became_stale and again.reason == contacts_reason(*LINKS)


# -- configuration and bad input -----------------------------------------------------------------
def test_timeouts_can_be_replaced_at_run_time() -> None:
    f = fresh_at(T0)
    assert f.stale_reason(T0 + 0.2) is not None
    f.config = FreshnessConfig(contact_timeout=0.5, joint_state_timeout=0.5, odom_timeout=0.5)
    assert f.stale_reason(T0 + 0.2) is None


@pytest.mark.parametrize("field", ["contact_timeout", "joint_state_timeout", "odom_timeout"])
@pytest.mark.parametrize("value", [0.0, -0.1, math.nan, math.inf])
def test_bad_timeouts_are_refused_naming_the_field(field: str, value: float) -> None:
    kwargs = {"contact_timeout": 0.1, "joint_state_timeout": 0.1, "odom_timeout": 0.1}
    kwargs[field] = value
    with pytest.raises(ValueError, match=rf"{field} = .*finite number > 0"):
        FreshnessConfig(**kwargs)


def test_bad_names_and_times_are_refused() -> None:
    with pytest.raises(ValueError, match="links = "):
        InputFreshness((), JOINTS, CONFIG)
    with pytest.raises(ValueError, match=r"joints = .*repeats"):
        InputFreshness(LINKS, ("a", "a"), CONFIG)
    f = make()
    with pytest.raises(ValueError, match="link = 'elbow_link': not one of"):
        f.contact_arrived("elbow_link", T0)
    for arrive in (lambda t: f.contact_arrived(LINKS[0], t), lambda t: f.joints_arrived(LEFT, t),
                   f.odom_arrived):
        with pytest.raises(ValueError, match="now = nan s: must be finite"):
            arrive(math.nan)
    assert f.stale_reason(T0) == contacts_reason(*LINKS), "a refused arrival changes nothing"
    with pytest.raises(TypeError):
        f.contact_time[LINKS[0]] = T0  # type: ignore[index]


# -- F9 refused input ----------------------------------------------------------------------------
def test_refused_inputs_are_stale_until_their_next_valid_message() -> None:
    f = fresh_at(T0)
    assert f.check(T0).reason is None
    f.contact_refused(LINKS[1])
    verdict = f.check(T0)
    assert verdict.reason == f"{STALE_CONTACTS}: {LINKS[1]}" and verdict.became_stale
    f.contact_arrived(LINKS[1], T0)
    assert f.check(T0).reason is None
    f.joints_refused({JOINTS[0]})
    assert f.check(T0).reason == STALE_JOINTS
    f.joints_arrived(JOINTS, T0)
    f.odom_refused()
    assert f.check(T0).reason == STALE_ODOMETRY
    f.odom_arrived(T0)
    assert f.check(T0).reason is None
    with pytest.raises(ValueError, match="not one of"):
        f.contact_refused("elbow")


# -- docs ----------------------------------------------------------------------------------------
def test_docs_list_every_rule_and_reason() -> None:
    """docs/wholebody_controller.md, section "Input freshness", names each rule of the module
    docstring (``F<n>. <title>``) and each reason the node logs."""
    text = DOC.read_text(encoding="utf-8")
    section = text.split("## Input freshness", 1)[1].split("\n## ", 1)[0]
    rules = re.findall(r"^(F\d+)\. ([^:]+):", freshness_module.__doc__ or "", re.MULTILINE)
    assert [r[0] for r in rules] == [f"F{i}" for i in range(1, 10)]
    missing = [f"{n}. {title}" for n, title in rules
               if f"**{n}. {' '.join(title.split())}**" not in section]
    assert not missing, f"rules missing from the docs: {missing}"
    assert all(f"`{reason}" in section for reason in REASONS), REASONS
