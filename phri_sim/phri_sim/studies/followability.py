"""The followability map through the real nodes: each lead of :mod:`phri_sim.studies.leads` run
lock-step.

:func:`run_lead` runs one lead scenario with :func:`phri_sim.ros.runner.run_scenario` (the real
contact estimation and whole-body controller, or the zero-command stub = a motionless robot);
:func:`run_map` runs the search of :func:`phri_sim.studies.leads.followability_map` with it. The
short form (:data:`SHORT_FORM`, CI) tries two speeds per direction on shorter leads.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from phri_sim.evaluation.following_metrics import Bars
from phri_sim.ros.run_options import RunOptions
from phri_sim.ros.runner import run_scenario
from phri_sim.studies.leads import (
    FULL_TIMING,
    HEADINGS_DEG,
    SHORT_TIMING,
    SPEEDS,
    TURN_RATES,
    Lead,
    LeadTiming,
    Profile,
    followability_map,
    lead_scenario,
)
from phri_sim.world.actuators import DEFAULT_PLANT


@dataclass(frozen=True)
class MapForm:
    """Which leads the map tries: their timing, headings [deg], speeds [m/s], turn rates
    [rad/s]."""

    timing: LeadTiming
    headings: tuple[float, ...]
    speeds: tuple[float, ...]
    turn_rates: tuple[float, ...]


FULL_FORM = MapForm(FULL_TIMING, HEADINGS_DEG, SPEEDS, TURN_RATES)
SHORT_FORM = MapForm(SHORT_TIMING, HEADINGS_DEG, (0.05, 0.1), (0.1, 0.3))
"""CI: 8 headings at 0.05 then 0.1 m/s, both turns at 0.1 then 0.3 rad/s; 0.15 m or 30° each."""


def run_lead(lead: Lead, profile: Profile, *, controller: str = "node",
             seed: int = 0, base: str = "waltz", plant: str = DEFAULT_PLANT) -> dict[str, Any]:
    """Metrics of one lead (``controller`` 'node' = the whole-body controller, 'stub' = a
    motionless robot) from the hold of scenario ``base`` (its controller parameters) on
    ``plant``."""
    return run_scenario(lead_scenario(lead, profile, base),
                        RunOptions(duration=profile.duration, seed=seed, controller=controller,
                                   plant=plant))


def run_map(form: MapForm = FULL_FORM, bars: Bars | None = None, *, controller: str = "node",
            seed: int = 0, progress: Callable[[Lead, dict[str, Any]], None] | None = None,
            base: str = "waltz", plant: str = DEFAULT_PLANT) -> dict[str, Any]:
    """The followability map (:func:`phri_sim.studies.leads.followability_map`) through the nodes,
    with the form, controller and CPU time it took."""
    bars = bars or Bars()
    cpu = time.process_time()

    def run(lead: Lead) -> dict[str, Any]:
        metrics = run_lead(lead, form.timing.profile(lead), controller=controller, seed=seed,
                           base=base, plant=plant)
        if progress is not None:
            progress(lead, metrics)
        return metrics

    out = followability_map(run, bars, form.headings, form.speeds, form.turn_rates)
    out.update({"timing": vars(form.timing), "controller": controller, "seed": seed,
                "scenario": base, "plant": plant,
                "cpu_time": time.process_time() - cpu})
    return out
