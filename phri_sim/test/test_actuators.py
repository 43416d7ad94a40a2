"""The realistic plant's drives (phri_sim.world.actuators): latency, acceleration and jerk limits,
velocity-loop lag, the RTDE cycle and speedJ's ramp, each against a known answer; the plant in
the simulation."""

from __future__ import annotations

import math

import numpy as np
import pytest

from phri_sim.scenarios.catalogue import Q_HOME
from phri_sim.world.actuators import (
    PLANTS,
    ArmDrive,
    BaseDrive,
    CommandShaper,
    JerkLimitedRamp,
    Plant,
    drive_tick,
    plant_named,
)
from phri_sim.world.simulation import SimConfig, Simulation
from phri_sim.world.skin_footprint import SkinConfig

DT = 0.005


def _response(plant: Plant, u: np.ndarray, seconds: float, dt: float = DT) -> np.ndarray:
    """Servo set points per physics step for a command ``u`` held from t = 0."""
    shaper = CommandShaper(plant, dt)
    return np.array([shaper(u) for _ in range(round(seconds / dt))])


def _base_only(**drive: object) -> Plant:
    return Plant("test", base=BaseDrive(**drive), arm=None, skin_pipeline=False)  # type: ignore[arg-type]


def test_ramp_respects_acceleration_and_jerk_and_lands_without_overshoot() -> None:
    """A 0.3 m/s step: |a| ≤ A and |Δa| ≤ J·h at every tick, no overshoot, exactly at rest on
    the target once there; a reversal brakes the acceleration first (jerk-limited)."""
    ramp = JerkLimitedRamp((1.0,), (20.0,))
    h = 0.001
    values, accels = [], []
    for k in range(3000):
        target = [0.3] if k < 1500 else [-0.2]
        values.append(ramp.step(target, h)[0])
        accels.append(ramp.accel[0])
    v, a = np.array(values), np.array(accels)
    assert np.max(np.abs(a)) <= 1.0 + 1e-12
    assert np.max(np.abs(np.diff(a))) <= 20.0 * h + 1e-12
    assert np.max(v[:1500]) <= 0.3 + 1e-9
    assert v[1499] == 0.3 and a[1499] == 0.0
    assert v[-1] == -0.2 and np.min(v) >= -0.2 - 1e-9
    # Time to a 0.3 m/s change: 0.3 / A plus A / J for the two jerk phases = 0.35 s.
    first = int(np.argmax(v >= 0.3))
    assert first * h == pytest.approx(0.3 / 1.0 + 1.0 / 20.0, abs=0.01)


def test_base_latency_delays_the_first_motion_by_exactly_the_latency() -> None:
    out = _response(_base_only(latency=0.020, lag=0.0), np.array([0.1] + [0.0] * 14), 0.1)
    moving = np.flatnonzero(out[:, 0] > 0.0)
    assert moving[0] * DT == pytest.approx(0.020)


def test_base_lag_is_first_order_with_its_time_constant() -> None:
    """With ramps that never bind, the set point rises as 1 − exp(−t/τ): 63 % at τ."""
    plant = _base_only(latency=0.0, lag=0.05, acceleration=(1e6, 1e6, 1e6),
                       jerk=(1e9, 1e9, 1e9))
    shaper = CommandShaper(plant, 0.001)
    out = np.array([shaper(np.array([0.0, 0.2] + [0.0] * 13))[1] for _ in range(300)])
    t = (np.arange(300) + 0.5) * 0.001  # each value is the mean over its 1 ms step
    np.testing.assert_allclose(out, 0.2 * (1.0 - np.exp(-t / 0.05)), atol=2e-3)


def test_realistic_base_accelerates_at_the_rated_limits() -> None:
    """The default base: a step of 0.5 m/s and 1 rad/s reaches them no faster than 1.0 m/s²
    and 1.5 rad/s² (the set point's own differences per physics step)."""
    out = _response(PLANTS["realistic"], np.array([0.5, 0.0, 1.0] + [0.0] * 12), 2.0)
    accel = np.abs(np.diff(out[:, :3], axis=0)) / DT
    assert accel[:, 0].max() <= 1.0 + 1e-9
    assert accel[:, 2].max() <= 1.5 + 1e-9
    assert out[-1, 0] == pytest.approx(0.5, abs=1e-6)
    assert out[-1, 2] == pytest.approx(1.0, abs=1e-6)


def test_speedj_ramps_the_leading_axis_and_scales_the_others_after_one_cycle() -> None:
    """RTDE at 500 Hz, one cycle of latency, speedJ at 2 rad/s² on the leading axis: joint 1
    (Δ = 0.4) leads, joint 2 (Δ = 0.1) arrives at the same time; the other arm is untouched."""
    plant = Plant("test", base=None, arm=ArmDrive(), skin_pipeline=False)
    shaper = CommandShaper(plant, 0.002)
    u = np.zeros(15)
    u[3], u[4] = 0.4, 0.1
    out = np.array([shaper(u) for _ in range(150)])
    assert out[0, 3] == 0.0  # read at the first cycle, executed at the next
    assert out[1, 3] == pytest.approx(2.0 * 0.002)
    np.testing.assert_allclose(out[:, 4], out[:, 3] / 4.0, atol=1e-12)
    arrive = int(np.argmax(out[:, 3] >= 0.4))
    assert arrive == int(np.argmax(out[:, 4] >= 0.1)) == 100  # 1 + 0.4 / (2.0 · 0.002) − 1
    assert np.all(out[:, 9:] == 0.0)


def test_the_ideal_plant_passes_commands_through() -> None:
    sim = Simulation(SimConfig(plant="ideal"))
    assert sim.shaper is None and sim.robot.shaper is None
    assert not PLANTS["ideal"].shapes_commands and PLANTS["realistic"].shapes_commands


def test_the_simulated_base_follows_a_turn_command_at_the_rated_acceleration() -> None:
    """On the realistic plant a yaw command of 100 rad/s is clipped to the base's limit (1 rad/s)
    and reached after its ramp: 1.0 / 1.5 rad/s² plus the jerk phase, the latency and the lag
    (≈ 0.8 s); never faster than the rated acceleration."""
    sim = Simulation(SimConfig(skin=SkinConfig(noise_std=0.0), plant="realistic"))
    sim.reset(np.array(Q_HOME))
    rates = []
    for _ in range(300):
        sim.command("base", np.array([0.0, 0.0, 100.0]))
        sim.step(2)
        rates.append(sim.qd[2])
    rates_arr = np.array(rates)
    limit = sim.robot.velocity_limits[2]
    assert rates_arr[-1] == pytest.approx(limit, rel=0.01)
    assert np.max(np.diff(rates_arr)) / (2 * sim.dt) <= 1.5 * 1.05
    assert rates_arr[int(0.5 / (2 * sim.dt))] < 0.9 * limit  # not there at once


def test_settling_and_reset_leave_the_drives_at_rest() -> None:
    sim = Simulation(SimConfig(plant="realistic"))
    assert sim.shaper is not None
    sim.command("base", np.array([0.3, 0.0, 0.0]))
    sim.step(20)
    sim.reset(np.array(Q_HOME))
    sim.step(1)
    assert sim.shaper(np.zeros(15)).tolist() == [0.0] * 15


def test_bad_drive_values_and_plants_are_refused_by_name() -> None:
    with pytest.raises(ValueError, match="base latency"):
        BaseDrive(latency=-0.01)
    with pytest.raises(ValueError, match="jerk"):
        BaseDrive(jerk=(1.0, 0.0, 1.0))
    with pytest.raises(ValueError, match="speedJ acceleration"):
        ArmDrive(acceleration=0.0)
    with pytest.raises(ValueError, match="plant 'rough' unknown"):
        plant_named("rough")
    with pytest.raises(ValueError, match="plant"):
        SimConfig(plant="rough")
    with pytest.raises(ValueError, match="drive ticks"):
        CommandShaper(_base_only(latency=0.0125), 0.005)
    assert drive_tick(0.005) == 0.001 and drive_tick(0.0005) == 0.0005
    with pytest.raises(ValueError, match="whole fraction"):
        drive_tick(0.0015)
    assert math.isclose(sum(BaseDrive().acceleration), 3.5)
