"""Study: when following fails — the peak and held force per body part of the partner.

The cases where following fails (docs/phri_sim.md, "Safe when following fails"), through the
real nodes in lock-step (``phri_sim.ros.runner``), each printed as the peak and the
0.5 s-sustained ("held") force per person body part and per robot link against ISO/TS 15066
(``metrics.json`` → ``iso15066``):

* ``waltz``: the default waltz at the paper tempo (also its band, drift, heading and peak force:
  the dance itself must not change);
* ``waltz_x2``: the same routine time-compressed twice (beat 2.75 s instead of 5.5 s);
* ``waltz_tempo``: the catalogue's ``waltz_tempo`` (bar 2 s);
* ``couple_turn_fast``: the waltz hold turned about the couple's centre at −1.0 rad/s (a fast
  couple turn to the right, 90°; ``phri_sim.studies.leads``);
* ``wrist_walk``: the partner walks forward along the left forearm at 0.5 m/s for 0.40 m, past
  the forearm's end into the unsensed left wrist (2.5× the fastest lead along the forearm the
  robot follows, docs/wholebody_controller.md);
* ``pinch_walk``: the partner walks at 0.3 m/s for 0.40 m towards the robot's right (away from
  the left forearm), between the two arms into the right arm's forearm and wrist.

Beside each part's peak the table gives who moved into whom at that instant: the largest speed
of a robot point towards the part among its contacts (``robot→``) and of the part's point towards
the robot (``→robot``), along the contact normal [m/s]: a peak with the robot still and the
partner moving is the partner walking into a standing robot, not a squeeze by the robot.

Each case runs twice: ``before`` — a robot without either guard (the controller's
``unsensed_guard`` off and the arms' simulated protective stop off: the robot before these
guards) — and ``after`` — both on (the defaults).

Run: ``.venv/bin/python bench/bench_pinch.py [--cases waltz_x2 wrist_walk] [--out DIR]
[--jobs 2] [--only before|after]``; each run's metrics go to ``DIR/<case>_<variant>.json`` and a
table is printed.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import multiprocessing
import os
from collections.abc import Callable
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np

from phri_common.testing import isolate_ros_environment
from phri_sim.scenarios.catalogue import SCENARIOS, Scenario, waltz_script
from phri_sim.scenarios.waltz_choreography import TEMPOS, waltz_choreography
from phri_sim.studies.leads import Lead, LeadTiming, lead_scenario


def waltz_x2() -> Scenario:
    """The default waltz's routine at twice the paper tempo (beat 2.75 s)."""
    tempo = dataclasses.replace(TEMPOS["paper"], name="paper_x2", beat=TEMPOS["paper"].beat / 2)
    base = SCENARIOS["waltz"]
    duration = waltz_choreography(tempo, 2.0, 3.0).duration
    return dataclasses.replace(base, name="waltz_x2", duration=duration,
                               short_duration=duration,
                               make_script=partial(waltz_script, tempo=tempo))


def _lead(lead: Lead, distance: float) -> Scenario:
    timing = LeadTiming(distance=distance, angle=0.5 * 3.141592653589793)
    return lead_scenario(lead, timing.profile(lead))


CASES: dict[str, Callable[[], Scenario]] = {
    "waltz": lambda: SCENARIOS["waltz"],
    "waltz_x2": waltz_x2,
    "waltz_tempo": lambda: SCENARIOS["waltz_tempo"],
    "couple_turn_fast": lambda: _lead(Lead("turn", -1.0), 0.3),
    "wrist_walk": lambda: _lead(Lead("translate", 0.5, 0.0), 0.40),
    "pinch_walk": lambda: _lead(Lead("translate", 0.3, 270.0), 0.40),
}


VARIANTS = ("before", "after")


class PeakWitness:
    """Per person part: at its peak contact force, the approach speeds of the robot and of the
    part along the contact normals (module docstring) [m/s]."""

    def __init__(self, sim: Any) -> None:
        import mujoco

        self.mujoco, self.sim = mujoco, sim
        m = sim.model
        self.part_of = {g: m.geom(g).name for g in range(m.ngeom)
                        if m.geom(g).name.startswith("person_")}
        self.peaks: dict[str, dict[str, float]] = {}
        self._wrench, self._vel = np.zeros(6), np.zeros(6)

    def _point_velocity(self, body: int, point: np.ndarray) -> np.ndarray:
        self.mujoco.mj_objectVelocity(self.sim.model, self.sim.data, self.mujoco.mjtObj.mjOBJ_BODY,
                                      body, self._vel, 0)
        return np.asarray(self._vel[3:] + np.cross(self._vel[:3],
                                                   point - self.sim.data.xpos[body]))

    def step(self) -> None:
        m, d = self.sim.model, self.sim.data
        forces: dict[str, list[tuple[float, float, float]]] = {}
        for i in range(d.ncon):
            con = d.contact[i]
            g1, g2 = int(con.geom1), int(con.geom2)
            if (g1 in self.part_of) == (g2 in self.part_of):
                continue
            person, robot = (g1, g2) if g1 in self.part_of else (g2, g1)
            self.mujoco.mj_contactForce(m, d, i, self._wrench)
            normal = con.frame[:3] * (1.0 if person == g2 else -1.0)  # robot → person
            rv = self._point_velocity(int(m.geom_bodyid[robot]), con.pos)
            pv = self._point_velocity(int(m.geom_bodyid[person]), con.pos)
            forces.setdefault(self.part_of[person], []).append(
                (float(np.linalg.norm(self._wrench[:3])), float(rv @ normal),
                 float(-pv @ normal)))
        for part, rows in forces.items():
            total = sum(r[0] for r in rows)
            if total > self.peaks.get(part, {}).get("force", 0.0):
                self.peaks[part] = {"force": total, "time": self.sim.time,
                                    "robot_approach": max(r[1] for r in rows),
                                    "partner_approach": max(r[2] for r in rows)}


def run_case(name: str, variant: str, out: str, domain: int | None = None) -> dict[str, Any]:
    """Run one case in this process (ROS domain ``domain``, default one from the pid) and write
    its metrics: ``before`` without the unsensed-contact guard and the arms' protective stop,
    ``after`` with both."""
    if domain is not None:
        os.environ["PHRI_TEST_DOMAIN_ID"] = str(domain)
    isolate_ros_environment()
    import rclpy
    from rclpy.context import Context

    from phri_sim.ros.runner import RunOptions, ScenarioRun

    guarded = variant == "after"
    scenario = CASES[name]()
    scenario = dataclasses.replace(scenario, controller_parameters={
        **scenario.controller_parameters, "unsensed_guard": guarded})
    context = Context()
    rclpy.init(context=context)
    run = ScenarioRun(scenario, RunOptions(protective_stop=guarded), context=context)
    witness = PeakWitness(run.bridge.sim)
    metrics_hook = run.bridge.sim.on_step

    def on_step() -> None:
        if metrics_hook is not None:
            metrics_hook()
        witness.step()

    run.bridge.sim.on_step = on_step
    try:
        metrics = run.run()
    finally:
        run.close()
        context.try_shutdown()
    metrics["peak_witness"] = witness.peaks
    stop = run.bridge.sim.robot.protective_stop
    metrics["protective_stops"] = {side: stop.status(side).stops for side in stop.arms}
    metrics["unsensed_guard_stops"] = run.controller.torque_watch.report.stops
    (Path(out) / f"{name}_{variant}.json").write_text(json.dumps(metrics, indent=1) + "\n",
                                                      encoding="utf-8")
    return metrics


def table(name: str, metrics: dict[str, Any]) -> str:
    """The case's forces per person part and robot link: peak / held [N] (limit ok?)."""
    iso = metrics["iso15066"]
    rows = []
    witness = metrics.get("peak_witness", {})
    for kind in ("person", "robot_links"):
        for part, row in sorted(iso[kind].items()):
            if row["peak_force"] <= 0.0:
                continue
            flag = "" if row["ok"] else "  NOT OK"
            seen = witness.get(part)
            who = "" if seen is None else (f"  (robot→ {seen['robot_approach']:+.2f}, →robot "
                                           f"{seen['partner_approach']:+.2f} m/s at "
                                           f"{seen['time']:.2f} s)")
            rows.append(f"  {part:24s} {row['peak_force']:8.1f} / {row['sustained_force']:7.1f} N"
                        f"{flag}{who}")
    following = metrics.get("following", {})
    extra = ""
    if following:
        extra = (f"\n  band {100 * following['band_share']:.1f} %, heading drift max "
                 f"{following['heading_drift_max_deg']:.1f}°, position drift RMS "
                 f"{100 * following['position_drift_rms']:.1f} cm, violations "
                 f"{metrics['limit_violations']}")
    stops = metrics.get("protective_stops", {})
    guard = metrics.get("unsensed_guard_stops", 0)
    return (f"{name}: iso15066 ok = {iso['ok']}, protective stops {stops}, guard stops "
            f"{guard}\n" + "\n".join(rows) + extra)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", nargs="*", default=list(CASES), choices=list(CASES))
    parser.add_argument("--out", default="runs/pinch")
    parser.add_argument("--jobs", type=int, default=1)
    parser.add_argument("--only", choices=VARIANTS, default=None)
    parser.add_argument("--domain", type=int, default=150,
                        help="ROS domain of the first run; each run its own (default 150 on)")
    args = parser.parse_args(argv)
    Path(args.out).mkdir(parents=True, exist_ok=True)
    pairs = [(c, v) for c in args.cases for v in VARIANTS if args.only in (None, v)]
    runs = [(c, v, args.out, args.domain + i) for i, (c, v) in enumerate(pairs)]
    ctx = multiprocessing.get_context("spawn")
    with ctx.Pool(max(1, args.jobs)) as pool:
        results = pool.starmap(run_case, runs)
    for (name, variant, _, _), metrics in zip(runs, results, strict=True):
        print(table(f"{name} ({variant})", metrics))
    summary = {f"{c}_{v}": m["iso15066"] for (c, v), m in zip(pairs, results, strict=True)}
    (Path(args.out) / "summary.json").write_text(json.dumps(summary, indent=1) + "\n",
                                                 encoding="utf-8")


if __name__ == "__main__":
    main()
