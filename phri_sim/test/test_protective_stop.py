"""The UR16e's own protective stop in the simulator (``phri_sim.world.protective_stop``) and the
drives' efforts (``SimRobot.efforts``).

A push on an unsensed link (a wrist: no skin) is applied as an external force on its body, as a
person's hand or body would; the arm must stop itself past what the UR's force limit allows,
hold, refuse an unlock within 5 s, re-arm only on a near-zero command — and never stop in plain
motion. The references are independent of the module: gravity from masses and centres, the
allowed torques from the force limit times levers measured on MuJoCo's frames."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from phri_sim.scenarios.catalogue import Q_WALTZ
from phri_sim.world.protective_stop import ProtectiveStopConfig, StopPhase
from phri_sim.world.simulation import SimConfig, Simulation
from phri_sim.world.skin_footprint import SkinConfig

WRIST = "left_wrist_3_link"
PUSH = np.array([0.0, 1.0, 0.0])  # world +y: sideways on the outward-turned left wrist


def _sim(enabled: bool = True, **config: object) -> Simulation:
    stop = ProtectiveStopConfig(enabled=enabled, **config)  # type: ignore[arg-type]
    sim = Simulation(SimConfig(skin=SkinConfig(noise_std=0.0), timestep=0.005,
                               protective_stop=stop))
    sim.reset(np.array(Q_WALTZ))
    return sim


RATED = 2.0
"""The arms' rated acceleration [rad/s²] (the controller's, the bridge's speedJ): commands ramp
at it, as the UR's own speedJ does."""


def _run(sim: Simulation, seconds: float, push: float = 0.0,
         left: np.ndarray | None = None) -> None:
    """Step ``seconds`` with ``push`` [N] along :data:`PUSH` on the wrist and the left arm
    commanded towards ``left`` [rad/s] (default zero) at the rated acceleration."""
    body = sim.model.body(WRIST).id
    target = np.zeros(6) if left is None else left
    for _ in range(round(seconds / sim.dt)):
        step = RATED * sim.dt
        sim.left_command = getattr(sim, "left_command", np.zeros(6))  # type: ignore[attr-defined]
        sim.left_command = sim.left_command + np.clip(target - sim.left_command, -step, step)
        sim.command("base", np.zeros(3))
        sim.command("left", sim.left_command)
        sim.command("right", np.zeros(6))
        sim.data.xfrc_applied[body, :3] = push * PUSH
        sim.step()


def test_efforts_at_rest_are_the_gravity_torques() -> None:
    """Still arms: each arm drive carries the gravity torque of the bodies beyond it,
    Σ (a × (c − o)) · m g (the servo torque of the gravity-compensated model plus the
    compensation), the base drives nothing."""
    sim = _sim()
    _run(sim, 0.2)
    m, d = sim.model, sim.data
    efforts = sim.robot.efforts()
    for i, name in enumerate(sim.joint_names[3:], start=3):
        joint = m.joint(name).id
        expected = 0.0
        for body in range(1, m.nbody):
            b = body
            while b > 0 and b != m.jnt_bodyid[joint]:
                b = m.body_parentid[b]
            if b > 0 and not m.body(body).name.startswith("person"):
                weight = np.array([0.0, 0.0, -9.81 * m.body_mass[body]])
                expected -= np.dot(d.xaxis[joint], np.cross(d.xipos[body] - d.xanchor[joint],
                                                            weight))
        assert efforts[i] == pytest.approx(expected, abs=0.05), name
    assert np.max(np.abs(efforts[:3])) < 0.05


def test_allowed_torques_are_the_force_limit_at_the_nearest_reference_point() -> None:
    """τ_allowed,j = 150 N × the distance from joint j's axis to the elbow (shoulder joints) or
    the tool flange, whichever is nearer, at least 0.1 m."""
    sim = _sim()
    d = sim.data
    mujoco.mj_forward(sim.model, d)
    stop = sim.robot.protective_stop
    allowed = stop._allowed(stop.arms["left"])

    def lever(joint: str, point: np.ndarray) -> float:
        j = sim.model.joint(joint).id
        r = point - d.xanchor[j]
        return float(np.linalg.norm(np.cross(r, d.xaxis[j])))

    elbow = d.xanchor[sim.model.joint("left_elbow_joint").id]
    tool = d.xpos[sim.model.body("left_tool0").id]
    for k, name in enumerate(sim.joint_names[3:9]):
        points = (elbow, tool) if k < 2 else (tool,)
        expected = 150.0 * max(min(lever(name, p) for p in points), 0.1)
        assert allowed[k] == pytest.approx(expected, rel=1e-9), name


def test_a_push_on_an_unsensed_wrist_stops_the_arm_which_holds() -> None:
    sim = _sim()
    stop = sim.robot.protective_stop
    _run(sim, 0.5, push=60.0)  # within every joint's allowed torque
    assert stop.status("left").safety_mode == "NORMAL"
    _run(sim, 0.05, push=400.0)
    status = stop.status("left")
    assert status.protective_stopped and status.safety_mode == "PROTECTIVE_STOP"
    assert abs(status.last_torque) > status.last_allowed
    q_stop = sim.q[3:9].copy()
    _run(sim, 1.0, push=400.0, left=np.full(6, 0.1))  # commands are ignored: it holds
    assert np.max(np.abs(sim.q[3:9] - q_stop)) < 0.01
    assert stop.status("right").safety_mode == "NORMAL"  # the other arm is not stopped


def test_unlock_waits_five_seconds_and_the_arm_rearms_on_a_small_command() -> None:
    sim = _sim(auto_unlock=False)
    stop = sim.robot.protective_stop
    _run(sim, 0.05, push=400.0)
    assert stop.status("left").protective_stopped
    _run(sim, 1.0)
    done, message = stop.unlock("left")
    assert not done and "5s" in message
    _run(sim, 4.0)
    assert stop.unlock("left")[0]
    assert stop.status("left").phase == StopPhase.DISARMED.value
    q = sim.q[3:9].copy()
    sim.left_command = np.full(6, 0.1)  # type: ignore[attr-defined]  # commanded all along
    _run(sim, 0.2, left=np.full(6, 0.1))  # the speed commanded before: not taken up
    assert np.max(np.abs(sim.q[3:9] - q)) < 0.002
    assert stop.status("left").phase == StopPhase.DISARMED.value
    _run(sim, 0.1, left=np.zeros(6))  # ramped down to near zero: re-armed
    assert stop.status("left").phase == StopPhase.NORMAL.value
    _run(sim, 0.2, left=np.full(6, 0.1))
    assert np.min(np.abs(sim.q[3:9] - q)) > 0.01


def test_the_simulated_operator_unlocks_once_the_contact_is_gone() -> None:
    sim = _sim()
    stop = sim.robot.protective_stop
    _run(sim, 6.0, push=400.0)  # past the 5 s, but still pressed: stays stopped
    assert stop.status("left").protective_stopped
    _run(sim, 0.9)  # gone, but not yet for clear_time (1 s)
    assert stop.status("left").protective_stopped
    _run(sim, 0.2)
    status = stop.status("left")  # unlocked, and re-armed at once by the zero command
    assert not status.protective_stopped and status.stops == 1


def test_without_the_protective_stop_the_push_moves_the_arm_on() -> None:
    """The break check of the tests above: an arm without its safety system never stops; the
    push and the command carry it on."""
    sim = _sim(enabled=False)
    q = sim.q[3:9].copy()
    _run(sim, 0.5, push=400.0, left=np.full(6, 0.1))
    assert not sim.robot.protective_stop.status("left").protective_stopped
    assert np.max(np.abs(sim.q[3:9] - q)) > 0.03


def test_motion_within_the_rated_accelerations_never_trips() -> None:
    """Base and arms moving (sinusoids at the rated accelerations, no contact) for 8 s: what the
    arm's fixed-base model does not explain — the base's acceleration — never trips a stop."""
    sim = _sim()
    stop = sim.robot.protective_stop
    for k in range(800):
        t = k * 0.01
        sim.command("base", np.array([0.4 * math.sin(2.5 * t), -0.4 * math.sin(2.5 * t),
                                      0.6 * math.sin(2.5 * t)]))
        arm = 0.4 * math.sin(3.0 * t) * np.ones(6)
        sim.command("left", arm)
        sim.command("right", -arm)
        sim.step(2)
    assert stop.status("left").stops == 0 and stop.status("right").stops == 0
