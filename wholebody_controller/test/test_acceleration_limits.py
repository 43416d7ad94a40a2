"""Commands a real base and arm can execute: each command stays within the rated acceleration ×
the control period of the previous one, on every axis, whatever the contacts do; after a stop
the robot ramps up from rest; bad values are refused by name."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from wbc_scenarios import Q0, configs, touch_sequence

from phri_common.records import ContactState
from phri_common.testing import examples
from wholebody_controller.config import (
    ROBOT_ACCELERATION_LIMITS,
    ControllerConfig,
    LinkTaskConfig,
)
from wholebody_controller.controller import KinematicsModel, WholeBodyController

LINK = "left_forearm_link"
CENTER = np.array([-0.15, 0.0, 0.05])


@settings(max_examples=examples(0.3), suppress_health_check=[HealthCheck.too_slow])
@given(configs(), st.integers(0, 2**31 - 1), st.sampled_from([5.0, 40.0]))
def test_consecutive_commands_differ_by_at_most_the_rated_acceleration(
        config: ControllerConfig, seed: int, force_scale: float) -> None:
    from wholebody_controller.kinematics import RobotKinematics

    ctl = WholeBodyController(RobotKinematics(), config)
    change = np.asarray(config.acceleration_limits) * config.dt
    previous, q = np.zeros(15), Q0.copy()
    for contacts in touch_sequence(np.random.default_rng(seed), 80, force_scale, config.dt):
        result = ctl.step(q, contacts)
        assert np.all(np.abs(result.command - previous) <= change * (1 + 1e-9) + 1e-12)
        previous, q = result.command, q + config.dt * result.qdot


def _push(kin: KinematicsModel, config: ControllerConfig, steps: int) -> np.ndarray:
    """|command| per step and axis under a 60 N push on the left forearm (from rest)."""
    ctl = WholeBodyController(kin, config)
    q, out = Q0.copy(), []
    for k in range(steps):
        kin.update(q)
        rot, _ = kin.link_pose(LINK)
        force = np.asarray(rot).T @ np.array([0.0, 60.0, 0.0])
        contact = ContactState(LINK, k, True, CENTER, force, np.zeros(3), CENTER - 0.01,
                               CENTER + 0.01, 9)
        result = ctl.step(q, {LINK: contact})
        out.append(np.abs(result.command))
        q = q + config.dt * result.qdot
    return np.array(out)


def test_a_hard_push_ramps_the_base_up_at_its_rated_acceleration(kin: KinematicsModel) -> None:
    """The base's speed grows by at most 1 m/s² · 10 ms a period; with the bound lifted the
    same push jumps to its velocity limit at once (so the bound is what shapes the ramp)."""
    link = LinkTaskConfig(LINK, priority_lock=1.0)
    config = ControllerConfig(links=(link,), velocity_limit=0.5)
    ramped = _push(kin, config, 30)
    speed = np.hypot(ramped[:, 0], ramped[:, 1])
    assert speed[0] <= 0.01 * np.sqrt(2) + 1e-12
    assert np.all(np.diff(ramped[:, 0]) <= 0.01 + 1e-12)
    free = _push(kin, replace(config, acceleration_limits=(1e3,) * 15), 30)
    assert np.max(free[0, :2]) > 5 * np.max(ramped[0, :2])


def test_reset_takes_the_robot_as_stopped(kin: KinematicsModel) -> None:
    link = LinkTaskConfig(LINK, priority_lock=1.0)
    ctl = WholeBodyController(kin, ControllerConfig(links=(link,)))
    contact = ContactState(LINK, 0, True, CENTER, np.array([0.0, 40.0, 0.0]), np.zeros(3),
                           CENTER - 0.01, CENTER + 0.01, 9)
    for _ in range(20):
        ctl.step(Q0, {LINK: contact})
    assert np.any(ctl.previous_command != 0.0)
    ctl.reset()
    np.testing.assert_array_equal(ctl.previous_command, 0.0)
    result = ctl.step(Q0, {LINK: contact})
    change = np.asarray(ROBOT_ACCELERATION_LIMITS) * 0.01
    assert np.all(np.abs(result.command) <= change + 1e-12)


@pytest.mark.parametrize("bad", [0.0, -1.0, float("nan"), float("inf")])
def test_bad_acceleration_limit_is_refused_by_name(bad: float) -> None:
    values = list(ROBOT_ACCELERATION_LIMITS)
    values[2] = bad
    with pytest.raises(ValueError, match=r"'acceleration_limits\[2\]'"):
        ControllerConfig(acceleration_limits=tuple(values))
    with pytest.raises(ValueError, match=r"'acceleration_limits'.*15 elements"):
        ControllerConfig(acceleration_limits=ROBOT_ACCELERATION_LIMITS[:14])
