"""One control period of the world as a scenario plays it: the person's part, then the physics.

The lock-step bridge (:meth:`phri_sim.ros.bridge.SimBridgeNode.advance`) and the motionless
baseline (:mod:`phri_sim.ros.motionless`) both advance the world with :func:`period_steps`, so the
person, the shove and the physics are one implementation whether a robot is commanded or not.
"""

from __future__ import annotations

from collections.abc import Iterator

from phri_sim.scenarios.catalogue import Script
from phri_sim.world.shove import Shove
from phri_sim.world.simulation import Simulation


def period_steps(sim: Simulation, script: Script | None, shove: Shove,
                 steps: int) -> Iterator[int]:
    """Advance ``sim`` one control period of ``steps`` physics steps, yielding each step's index
    after it (a caller samples what it needs per step).

    The person's script is evaluated once, at the period's start; in between, each target moves
    on with its velocity (:meth:`~phri_sim.world.simulation.Simulation.set_target`), so it stays
    smooth. The shove's force [N] is set for the whole period at its start as well.
    """
    if script is not None:
        for part, target in script(sim.time).items():
            sim.set_target(part, target)
    shove.apply(sim, sim.time)
    for i in range(steps):
        sim.step()
        yield i
