"""The tempo ladder: the waltz from ×1 to a real slow waltz, with sway and unscripted leads, each
beside a motionless robot, against the bars — the inner loop of the controller work (``phri
ladder``, docs/phri_sim.md "Tempo ladder").

A :class:`Rung` is one scenario value and how long it runs. :func:`ladder_rungs` builds them:

* ``x1``, ``x2``, ``x4``: the default waltz time-compressed by K (``--tempo-scale K``); the
  quick form runs the first :data:`QUICK_LENGTH` = 30 s of each: at ×1 the hold, the closed
  change forward (a step away from the forearm, a side step along it, the close: the partner
  stands still 6 s, the time-to-rest bar) and the first bar of the natural turn (70° clockwise:
  turning lag, yaw fluctuation); at ×2 the closed change and the whole first natural turn
  (180°); at ×4 both natural turns (360° clockwise), the closed change back and the first
  reverse-turn beats. ``--full``: whole waltzes (186.5 / 95.8 / 51.1 s);
* ``tempo``: the ``tempo`` choreography (bar 2 s, its own parameter set), always whole (27 s);
* ``sway1`` …: the default waltz with ``--sway SEED`` (30 s each, whole with ``--full``);
* ``lead:<name>``: the unscripted leads
  (:data:`~phri_sim.studies.unscripted_leads.UNSCRIPTED_LEADS`), whole (7.6–14.9 s).

:func:`run_ladder` runs every rung on every plant with the whole-body controller and once with
the motionless robot (the baseline, :func:`phri_sim.ros.motionless.run_motionless`), in parallel
worker processes (each controller run in its own ROS domain, so runs cannot hear each other),
and :func:`ladder_lines` prints one table against each rung's bars
(:func:`~phri_sim.studies.leads.lead_passes`: the following bars, ISO/TS 15066, no limit
violations). A run is deterministic for its seed, so the table is too.
"""

from __future__ import annotations

import dataclasses
import multiprocessing
import os
import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from phri_sim.evaluation.following_metrics import BAR_SETS
from phri_sim.scenarios.catalogue import SCENARIOS, Partner, Scenario, with_partner
from phri_sim.studies.leads import lead_passes
from phri_sim.studies.unscripted_leads import UNSCRIPTED_LEADS, unscripted_scenario

QUICK_LENGTH = 30.0
"""Simulated length of the quick waltz rungs [s] (module docstring: what it covers)."""
TEMPO_SCALES = (1.0, 2.0, 4.0)
"""The rungs' tempo scales K."""
SWAY_SEEDS = (1, 2, 3)
"""The sway seeds of the default ladder."""
PLANT_NAMES = ("realistic", "ideal")


@dataclass(frozen=True)
class RungSpec:
    """What a worker needs to build a rung (picklable: names and numbers only).

    Attributes:
        name: ``x1``, ``x2``, ``x4``, ``tempo``, ``sway<seed>`` or ``lead:<name>``.
        full: whole waltzes instead of the quick form.
        parameters: controller parameters that replace the rung scenario's (``None``: its
            own), e.g. from ``phri ladder --params``.
        estimation: contact estimation parameters likewise.
    """

    name: str
    full: bool = False
    parameters: Mapping[str, Any] | None = None
    estimation: Mapping[str, Any] | None = None


@dataclass(frozen=True)
class Rung:
    """A rung: its scenario value and simulated length [s]."""

    name: str
    scenario: Scenario
    duration: float


def build_rung(spec: RungSpec) -> Rung:
    """The rung ``spec.name`` (module docstring); ValueError naming the known rungs."""
    name = spec.name
    if name.startswith("lead:"):
        lead = UNSCRIPTED_LEADS.get(name[5:])
        if lead is None:
            raise ValueError(f"rung {name!r}: unknown lead; known: "
                             f"{', '.join('lead:' + k for k in UNSCRIPTED_LEADS)}")
        sc = unscripted_scenario(lead)
    elif name == "tempo":
        sc = SCENARIOS["waltz_tempo"]
    elif name.startswith("sway") and name[4:].isdigit():
        sc = with_partner(SCENARIOS["waltz"], Partner(sway=int(name[4:])))
    elif name.startswith("x") and _number(name[1:]) is not None:
        sc = with_partner(SCENARIOS["waltz"], Partner(tempo_scale=_number(name[1:]) or 1.0))
    else:
        raise ValueError(f"rung {name!r} unknown: x<K> (e.g. x1, x2, x4), tempo, sway<SEED>, "
                         f"lead:<{'|'.join(UNSCRIPTED_LEADS)}>")
    if spec.parameters is not None or spec.estimation is not None:
        sc = dataclasses.replace(
            sc, controller_parameters=dict(spec.parameters or sc.controller_parameters),
            estimation_parameters=dict(spec.estimation or sc.estimation_parameters))
    quick = not (spec.full or name == "tempo" or name.startswith("lead:"))
    return Rung(name, sc, min(QUICK_LENGTH, sc.duration) if quick else sc.duration)


def _number(text: str) -> float | None:
    try:
        value = float(text)
    except ValueError:
        return None
    return value if value > 0.0 else None


def rung_names(scales: Iterable[float] = TEMPO_SCALES, tempo: bool = True,
               seeds: Iterable[int] = SWAY_SEEDS, leads: Iterable[str] = tuple(UNSCRIPTED_LEADS)
               ) -> list[str]:
    """The ladder's rung names in table order."""
    names = [f"x{k:g}" for k in scales] + (["tempo"] if tempo else [])
    return names + [f"sway{s}" for s in seeds] + [f"lead:{lead}" for lead in leads]


@dataclass(frozen=True)
class Task:
    """One run of the ladder: a rung on a plant with a controller (``node`` or ``stub``)."""

    rung: RungSpec
    plant: str
    controller: str
    seed: int = 0


def run_task(task: Task) -> dict[str, Any]:
    """Run one task in this process and return the condensed metrics (:func:`condense`): the
    controller's in a ROS domain of its own (101 + pid mod 100, localhost only); the motionless
    robot's (``stub``) on the world alone (:func:`phri_sim.ros.motionless.run_motionless`)."""
    import rclpy
    from rclpy.context import Context
    from rclpy.signals import SignalHandlerOptions

    from phri_sim.ros.motionless import run_motionless
    from phri_sim.ros.run_options import RunOptions
    from phri_sim.ros.runner import run_scenario

    rung = build_rung(task.rung)
    if task.controller == "stub":
        still, _ = run_motionless(rung.scenario, RunOptions(
            duration=rung.duration, seed=task.seed, plant=task.plant))
        return condense(still, rung)
    context = Context()
    rclpy.init(context=context, domain_id=101 + os.getpid() % 100,
               signal_handler_options=SignalHandlerOptions.NO)
    try:
        metrics = run_scenario(rung.scenario, RunOptions(
            duration=rung.duration, seed=task.seed, plant=task.plant,
            controller=task.controller), context=context)
    finally:
        context.try_shutdown()
    return condense(metrics, rung)


def condense(metrics: Mapping[str, Any], rung: Rung) -> dict[str, Any]:
    """What the ladder keeps of a run: the following block, the ISO/TS 15066 verdict, the limit
    violations, the verdict against the rung's bars, the timing."""
    bars = BAR_SETS[rung.scenario.bars]
    return {
        "rung": rung.name, "scenario": metrics.get("scenario"), "duration": rung.duration,
        "plant": metrics.get("plant"), "controller": metrics.get("controller"),
        "partner": metrics.get("partner"), "bars_name": rung.scenario.bars,
        "following": metrics["following"],
        "iso15066_ok": bool(metrics.get("iso15066", {}).get("ok", True)),
        "limit_violations": metrics.get("limit_violations", 0),
        "pass": lead_passes(dict(metrics), bars),
        "wall_time": metrics.get("wall_time"), "cpu_time": metrics.get("cpu_time"),
    }


Progress = Callable[[Task, dict[str, Any], float], None]


def run_ladder(rungs: Sequence[RungSpec], plants: Sequence[str] = ("realistic",), *,
               jobs: int | None = None, seed: int = 0, baseline: bool = True,
               progress: Progress | None = None,
               runner: Callable[[Task], dict[str, Any]] = run_task) -> dict[str, Any]:
    """Every rung on every plant with the controller (and, when ``baseline``, once with the
    motionless robot: never commanded, it is alike on every plant), ``jobs`` runs at a time
    (default: the CPU count; 1: in this process, with ``runner``), longest first; the results
    in task order with the wall time."""
    for spec in rungs:
        build_rung(spec)  # refuse an unknown rung before anything runs
    # The motionless robot commands zero, which every plant executes alike: one baseline per
    # rung, run on the first plant.
    tasks = [Task(spec, plant, "node", seed) for plant in plants for spec in rungs]
    if baseline:
        tasks += [Task(spec, plants[0], "stub", seed) for spec in rungs]
    order = sorted(range(len(tasks)), key=lambda i: -_cost(tasks[i]))
    start = time.perf_counter()
    results: dict[int, dict[str, Any]] = {}
    jobs = max(1, jobs or os.cpu_count() or 1)
    if jobs == 1:
        for i in order:
            results[i] = runner(tasks[i])
            if progress is not None:
                progress(tasks[i], results[i], time.perf_counter() - start)
    else:
        with multiprocessing.get_context("spawn").Pool(jobs) as pool:
            pending = {i: pool.apply_async(runner, (tasks[i],)) for i in order}
            for i in order:
                results[i] = pending[i].get()
                if progress is not None:
                    progress(tasks[i], results[i], time.perf_counter() - start)
    return {"runs": [results[i] for i in range(len(tasks))], "plants": list(plants),
            "wall_time": time.perf_counter() - start, "jobs": jobs, "seed": seed}


def _cost(task: Task) -> float:
    """A run's expected cost for scheduling: its simulated length, a third of it for the
    motionless robot (measured: 1.4 s of CPU against 4.4 s for the stub in lock-step over 20 s
    of the waltz, and the controller's run costs about as much as the stub's)."""
    share = 1.0 / 3.0 if task.controller == "stub" else 1.0
    return share * build_rung(task.rung).duration
