"""The simulated robot's command input: staleness, refusal, speed clipping, the applied command.

Expected values are written out from the contract (channel order, limits, timeout), not read from
the watchdog.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from phri_description.description import robot_description
from phri_sim.scenarios.catalogue import Q_HOME
from phri_sim.world.command_watchdog import CommandError, CommandWatchdog
from phri_sim.world.protective_stop import ProtectiveStopConfig
from phri_sim.world.simulation import SimConfig, Simulation
from phri_sim.world.skin_footprint import SkinConfig


def test_watchdog_next_change_is_when_a_command_goes_stale() -> None:
    wd = CommandWatchdog(0.1)
    assert wd.next_change(0.0) == math.inf
    wd.set("left", np.ones(6), 1.0)
    wd.set("base", np.ones(3), 1.05)
    assert wd.next_change(1.06) == pytest.approx(1.1)
    np.testing.assert_array_equal(wd.current("left", 1.0999), np.ones(6))
    np.testing.assert_array_equal(wd.current("left", 1.1001), np.zeros(6))
    assert wd.next_change(1.11) == pytest.approx(1.15)


def test_watchdog_zeroes_stale_and_refuses_nan() -> None:
    wd = CommandWatchdog(0.1)
    wd.set("left", np.ones(6), 1.0)
    np.testing.assert_array_equal(wd.current("left", 1.05), np.ones(6))
    np.testing.assert_array_equal(wd.current("left", 1.2), np.zeros(6))
    with pytest.raises(CommandError):
        wd.set("base", np.array([np.nan, 0.0, 0.0]), 1.0)
    np.testing.assert_array_equal(wd.current("base", 1.0), np.zeros(3))
    with pytest.raises(CommandError):
        wd.set("right", np.ones(5), 1.0)


def test_applied_is_base_then_arms_clipped_to_the_limits() -> None:
    limits = np.linspace(0.5, 2.0, 15)
    wd = CommandWatchdog(0.1, limits)
    wd.set("base", np.array([10.0, -10.0, 0.1]), 0.0)
    wd.set("left", np.full(6, -10.0), 0.0)
    wd.set("right", np.array([0.2, 0.0, 0.0, 0.0, 0.0, 30.0]), 0.0)
    expected = np.concatenate([[limits[0], -limits[1], 0.1], -limits[3:9],
                               [0.2, 0.0, 0.0, 0.0, 0.0, limits[14]]])
    np.testing.assert_array_equal(wd.applied(0.0), expected)
    np.testing.assert_array_equal(wd.received(0.0), [10.0, -10.0, 0.1, *[-10.0] * 6,
                                                     0.2, 0.0, 0.0, 0.0, 0.0, 30.0])


def test_applied_follows_every_new_command_and_the_timeout() -> None:
    """The applied command is cached between changes: a new command, a refused one and a
    channel going stale must each show at once."""
    wd = CommandWatchdog(0.1)
    wd.set("left", np.ones(6), 1.0)
    np.testing.assert_array_equal(wd.applied(1.0)[3:9], np.ones(6))
    wd.set("left", np.full(6, 2.0), 1.0)
    np.testing.assert_array_equal(wd.applied(1.0)[3:9], np.full(6, 2.0))
    np.testing.assert_array_equal(wd.applied(1.09)[3:9], np.full(6, 2.0))
    np.testing.assert_array_equal(wd.applied(1.11), np.zeros(15))
    wd.set("base", np.ones(3), 1.2)
    np.testing.assert_array_equal(wd.applied(1.2)[:3], np.ones(3))
    with pytest.raises(CommandError):
        wd.set("base", np.array([1.0, math.inf, 0.0]), 1.21)
    np.testing.assert_array_equal(wd.applied(1.21), np.zeros(15))


@pytest.mark.parametrize(("timeout", "limits", "field"), [
    (0.0, None, "timeout"), (math.nan, None, "timeout"),
    (0.1, np.ones(14), "limits"), (0.1, np.r_[np.ones(14), 0.0], "limits"),
])
def test_rejects_bad_settings(timeout: float, limits: np.ndarray | None, field: str) -> None:
    with pytest.raises(ValueError, match=field):
        CommandWatchdog(timeout, limits)


def test_simulated_speeds_are_clipped_to_the_description_limits() -> None:
    """Like the real drivers, the simulation caps commanded speeds at the description's limits:
    a base turn and a shoulder commanded at 100 rad/s move at their limits (on the ideal plant,
    whose servos get there within the test's 0.2 s; the realistic plant ramps to the same
    limits: test_actuators.py)."""
    # Without the arms' protective stop: a shoulder jumping to its speed limit in a few
    # milliseconds is a collision to it (the test is about the watchdog's clip).
    sim = Simulation(SimConfig(skin=SkinConfig(noise_std=0.0), plant="ideal",
                               protective_stop=ProtectiveStopConfig(enabled=False)))
    sim.reset(np.array(Q_HOME))
    limits = robot_description().velocity_limits()
    assert limits[2] < 100.0 and limits[3] < 100.0  # base yaw, left shoulder pan
    for _ in range(20):
        sim.command("base", np.array([0.0, 0.0, 100.0]))
        sim.command("left", np.array([100.0, 0.0, 0.0, 0.0, 0.0, 0.0]))
        sim.step(5)
    assert sim.qd[2] == pytest.approx(limits[2], rel=0.01)
    assert sim.qd[3] == pytest.approx(limits[3], rel=0.01)


def test_reset_forgets_the_commands() -> None:
    """A command given before a reset does not drive the robot after it (the clock went back to
    0, so without a fresh watchdog the old command would look fresh)."""
    sim = Simulation(SimConfig(skin=SkinConfig(noise_std=0.0)))
    sim.reset(np.array(Q_HOME))
    sim.step(25)
    sim.command("base", np.array([0.1, 0.0, 0.0]))
    sim.reset(np.array(Q_HOME))
    sim.step(25)
    np.testing.assert_allclose(sim.base_twist(), np.zeros(3), atol=1e-6)
