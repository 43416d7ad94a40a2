"""The force-controlled hand (phri_sim.scenarios.hand) in the physics: it holds its normal force
while the link moves away, lets go for real, and refuses touches off the skin.

References are physical, not copied from a run: the target force of the touch (the hand's spring
law F = K_h δ), and the geometry of the patch.
"""

from __future__ import annotations

import numpy as np
import pytest

from phri_sim.scenarios.catalogue import Q_HOME
from phri_sim.scenarios.hand import (
    GAP,
    LIFT,
    ForceHand,
    TouchOffSkinError,
    make_touch,
    normal_force,
)
from phri_sim.world.simulation import SimConfig, Simulation
from phri_sim.world.skin_footprint import SkinConfig

FORCE = 15.0
SIDE = (0.0, 1.0, 0.0)


def _run(sim: Simulation, hand: ForceHand, until: float, base_vy: float
         ) -> tuple[list[float], list[float], list[float]]:
    """Step ``sim`` to ``until`` with the base driven sideways at ``base_vy`` [m/s] and the hand
    scripted once per 10 ms; returns times, the left forearm's true normal force, the hand's
    distance from the link axis."""
    times, forces, gaps = [], [], []
    while sim.time < until - 1e-9:
        sim.set_target("person_left_hand", hand(sim.time))
        sim.command("base", np.array([0.0, base_vy, 0.0]))
        sim.command("left", np.zeros(6))
        sim.command("right", np.zeros(6))
        sim.step(5)
        truth = sim.ground_truth()["left_forearm_link"]
        times.append(sim.time)
        forces.append(truth.normal_force if truth.in_contact else 0.0)
        rot, pos = sim.link_pose("left_forearm_link")
        hand_pos, _ = sim.part_pose("person_left_hand")
        gaps.append(float(np.linalg.norm((rot.T @ (hand_pos - pos))[1:])))
    return times, forces, gaps


@pytest.fixture(scope="module")
def pressed() -> tuple[list[float], list[float], list[float]]:
    sim = Simulation(SimConfig(skin=SkinConfig(noise_std=0.0)))
    sim.reset(np.array(Q_HOME))
    touch = make_touch(sim, "left_forearm", 0.18, SIDE, 0.5, 3.0, FORCE)
    hand = ForceHand(sim, sim.part_pose("person_left_hand")[0], [touch])
    sim.set_target("person_left_hand", hand(0.0), teleport=True)
    # The base backs away from the hand (−y) at 0.1 m/s from 1.5 s to 2.5 s, and keeps going.
    out = _run(sim, hand, 1.5, 0.0)
    more = _run(sim, hand, 4.0, -0.1)
    return out[0] + more[0], out[1] + more[1], out[2] + more[2]


def test_the_press_holds_its_force_while_the_link_moves_away(pressed) -> None:
    times, forces, _ = pressed
    t, f = np.array(times), np.array(forces)
    still = f[(t > 1.2) & (t < 1.5)]
    moving = f[(t > 1.8) & (t < 2.9)]
    assert still.mean() == pytest.approx(FORCE, rel=0.05)
    # A world-fixed target would lose 0.1 m/s × 1 s × 400 N/m = 40 N: the press would be gone.
    assert moving.min() > 0.85 * FORCE and moving.max() < 1.15 * FORCE


def test_the_hand_lets_go_after_its_release(pressed) -> None:
    times, forces, gaps = pressed
    t, f, g = np.array(times), np.array(forces), np.array(gaps)
    after = t > 3.0 + 0.1 + 0.05
    assert np.all(f[after] == 0.0)  # released: no contact while the link keeps moving away
    assert g[-1] > g[t > 1.2][0] + 0.5 * LIFT


def test_force_profile_rises_holds_and_releases() -> None:
    sim = Simulation(SimConfig(skin=SkinConfig(noise_std=0.0)))
    sim.reset(np.array(Q_HOME))
    touch = make_touch(sim, "left_forearm", 0.18, SIDE, 1.0, 3.0, FORCE)
    assert normal_force(touch, 0.9) == 0.0
    assert normal_force(touch, 2.0) == pytest.approx(FORCE)
    assert normal_force(touch, 3.5) == pytest.approx(0.0, abs=1e-12)
    values = [normal_force(touch, x) for x in np.arange(0.0, 4.0, 0.01)]
    assert min(values) >= -1e-12 and max(values) <= FORCE + 1e-12
    assert GAP > 0.0


@pytest.mark.parametrize("s", [0.0, 0.5, -0.2])
def test_a_touch_off_the_skin_is_refused_with_the_allowed_range(s: float) -> None:
    sim = Simulation(SimConfig(skin=SkinConfig(noise_std=0.0)))
    sim.reset(np.array(Q_HOME))
    with pytest.raises(TouchOffSkinError, match=r"left_forearm.*allowed axial range \["):
        make_touch(sim, "left_forearm", s, SIDE, 1.0, 3.0, FORCE)


def test_a_slide_that_leaves_the_skin_raises_while_pressing() -> None:
    sim = Simulation(SimConfig(skin=SkinConfig(noise_std=0.0)))
    sim.reset(np.array(Q_HOME))
    touch = make_touch(sim, "left_forearm", 0.18, SIDE, 0.5, 3.0, FORCE,
                       slide=lambda t: 0.0 if t < 1.0 else 1.0)
    hand = ForceHand(sim, sim.part_pose("person_left_hand")[0], [touch])
    hand(0.9)
    with pytest.raises(TouchOffSkinError, match="sliding touch of left_forearm"):
        hand(1.1)
