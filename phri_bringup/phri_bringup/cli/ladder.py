"""``phri ladder``: the tempo ladder (:mod:`phri_sim.studies.ladder`) from the command line.

::

    phri ladder                          # every rung, realistic plant, robot and motionless
    phri ladder --plant both             # realistic and ideal plant (the "before" table)
    phri ladder --rungs x1,x4,lead:box   # some rungs only
    phri ladder --params my_waltz.yaml   # a controller parameter file for every rung
    phri ladder --full                   # whole waltzes instead of their first 30 s

Writes ``OUT/ladder.json`` (every run's following block and verdict) and ``OUT/ladder.md`` (the
table it prints); exit code 0 whether or not the bars are met (it measures), 2 for bad
arguments.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any


def add_parser(sub: Any, domain_argument: Any) -> None:
    """The ``phri ladder`` sub-command on ``sub`` (``domain_argument`` adds --ros-domain-id)."""
    del domain_argument  # every run picks a private domain of its own (parallel workers)
    ladder = sub.add_parser("ladder", help="the tempo ladder: the waltz at ×1, ×2, ×4 and "
                            "tempo, with sway and the unscripted leads, each beside a "
                            "motionless robot, in one table against the bars")
    ladder.add_argument("--out", default="runs/ladder", help="output directory")
    ladder.add_argument("--plant", choices=("realistic", "ideal", "both"), default="realistic",
                        help="the plant (both: the realistic and the ideal one)")
    ladder.add_argument("--rungs", default=None,
                        help="comma-separated rungs (default all): x<K> (x1, x2, x4, x1.5 …), "
                             "tempo, sway<SEED>, lead:<spin_left|spin_right|pivot_slow|"
                             "pivot_fast|back_away|box>")
    ladder.add_argument("--seeds", default="1,2,3", help="sway seeds of the default rungs")
    ladder.add_argument("--full", action="store_true",
                        help="whole waltzes (default: the first 30 s of the x<K> and sway rungs)")
    ladder.add_argument("--params", default=None,
                        help="parameter file whose controller and estimation sections replace "
                             "every rung's (e.g. a candidate config/waltz.yaml)")
    ladder.add_argument("--jobs", type=int, default=None,
                        help="runs at a time (default: the CPU count)")
    ladder.add_argument("--no-baseline", dest="baseline", action="store_false", default=True,
                        help="no motionless runs")
    ladder.add_argument("--seed", type=int, default=0, help="skin noise seed")


def rung_specs(args: argparse.Namespace) -> list[Any]:
    """The rungs of ``phri ladder``'s arguments.

    Raises:
        ValueError: an unknown rung, a bad seed list or a refused parameter file.
    """
    from phri_sim.studies.ladder import RungSpec, build_rung, rung_names

    try:
        seeds = [int(s) for s in args.seeds.split(",") if s.strip()]
    except ValueError:
        raise ValueError(f"--seeds {args.seeds!r}: comma-separated integers") from None
    names = ([n.strip() for n in args.rungs.split(",") if n.strip()] if args.rungs
             else rung_names(seeds=seeds))
    params, estimation = None, None
    if args.params is not None:
        from phri_bringup.cli.session import load_sections
        from phri_bringup.graph.nodes import CONTROLLER, ESTIMATION

        path = Path(args.params)
        if not path.is_file():
            raise ValueError(f"--params {args.params}: no such file")
        sections = load_sections("waltz", path)
        params, estimation = sections.get(CONTROLLER), sections.get(ESTIMATION)
    specs = [RungSpec(n, args.full, params, estimation) for n in names]
    for spec in specs:
        build_rung(spec)
    return specs


def cmd_ladder(args: argparse.Namespace) -> int:
    """``phri ladder``: run, print the table, write ladder.json and ladder.md."""
    from phri_bringup.reports.ladder_report import ladder_lines
    from phri_sim.studies.ladder import PLANT_NAMES, run_ladder

    specs = rung_specs(args)
    plants = list(PLANT_NAMES) if args.plant == "both" else [args.plant]
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)

    def report(task: Any, run: dict[str, Any], wall: float) -> None:
        verdict = "within the bars" if run["pass"]["all"] else "not within the bars"
        print(f"phri: {task.rung.name} ({task.plant}, {task.controller}): {verdict} "
              f"(wall {wall:.0f} s)", file=sys.stderr, flush=True)

    result = run_ladder(specs, plants, jobs=args.jobs, seed=args.seed, baseline=args.baseline,
                        progress=report)
    lines = ladder_lines(result)
    (out / "ladder.json").write_text(json.dumps(result, indent=2, allow_nan=True) + "\n",
                                     encoding="utf-8")
    (out / "ladder.md").write_text("\n".join(lines) + "\n", encoding="utf-8")
    for line in lines:
        print(line)
    print(f"phri: ladder: {out / 'ladder.json'}, {out / 'ladder.md'}", file=sys.stderr)
    return 0
