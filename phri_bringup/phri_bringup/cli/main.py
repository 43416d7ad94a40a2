"""The ``phri`` command: run a scenario headless and get a recording, plots, video and metrics.

::

    phri sim --scenario waltz --out runs/waltz     # all of it (recording, plots, video, metrics)
    phri sim --scenario centring --short --no-video
    phri sim --scenario waltz --foxglove          # live view on ws://localhost:8765
    phri sim --scenario waltz --fault skin_blind --fault-time 5   # rehearse a sensor fault
    phri sim --scenario waltz --tempo-scale 2 --sway 1 --no-video   # a faster partner who sways
    phri sim --lead spin_left --no-video          # an unscripted lead (spins, pivots, box, …)
    phri sim --plant ideal                        # servos that follow every command at once
                                                  # (default: realistic, a real robot's drives)
    phri ladder [--plant both] [--full]           # the tempo ladder against the bars
    phri followability [--short] [--tempo] --out runs/followability   # the followability map
    phri plot runs/waltz                          # panels again from the recording
    phri video runs/waltz                         # video again from the recording
    phri params --check | --write                 # parameter files vs the paper's values
    phri graph sim|real                           # the node graph the launch files start
    phri layouts DIR                              # nominal skin layout files for real.launch.py
    phri paper-report --page docs/paper_vs_phri.md   # Figs 6–8 panel by panel + paper vs phri

Exit codes: 0 done, 1 run failed, 2 bad arguments or parameters (one ``phri: error:`` line,
before anything starts), 130 stopped by Ctrl-C/SIGTERM (the robot was sent zero velocity and the
recording was closed either way).
"""

from __future__ import annotations

import argparse
import functools
import json
import os
import signal
import sys
import time
from pathlib import Path
from typing import Any, NoReturn

SCENARIO_CHOICES = ("centring", "sliding", "wholebody", "waltz", "waltz_tempo", "waltz_paper")
"""Every scenario ``phri sim`` runs (phri_bringup.graph.nodes.SCENARIO_FILES, kept here so ``phri
--help`` imports nothing heavy; a test checks they agree). ``waltz_tempo`` is ``--scenario waltz
--tempo tempo``, ``waltz_paper`` is ``--scenario waltz --params paper``."""
SCENARIO_HELP = (
    "centring (Fig. 6), sliding (Fig. 7), wholebody (Fig. 8), waltz (Fig. 1, the following "
    "set), waltz_tempo (the waltz at a real slow-waltz tempo, bar 2 s), waltz_paper (the waltz "
    "with the paper's literal parameter set); default waltz"
)
FAULT_CHOICES = ("skin_blind", "skin_stuck", "force_spike", "joint_jump", "skin_frozen_noisy",
                 "skin_half_dead", "skin_gain")
"""phri_sim.world.sensor_faults.FAULT_KINDS (kept here so ``phri --help`` does not import the
simulator; a test checks they agree)."""
FAULT_HELP = (
    "inject a sensor fault where a real one would enter (the simulated skin / joint-state "
    "publishing; the controller is not told): skin_blind = every taxel reads 0 N from the fault "
    "time on; skin_stuck = taxels freeze at their last values; force_spike = the most loaded "
    "taxel reads 3e38 N for one frame; joint_jump = the left elbow reads 10 rad in one joint "
    "state; skin_frozen_noisy = a patch repeats its last frame with 0.5 %% noise; "
    "skin_half_dead = half a patch reads 0 N; skin_gain = a patch reads --fault-value (3) × "
    "its force (--fault-patch: which patch, default every one). metrics.json → 'fault' reports "
    "what the robot did after it (peak forces against "
    "ISO/TS 15066, travel, time to stop / recover)"
)


def _log(text: str) -> None:
    print(f"phri: {text}", file=sys.stderr, flush=True)


class _Parser(argparse.ArgumentParser):
    """argparse with one-line errors: ``phri sim: error: … (phri sim --help)``, exit code 2."""

    def error(self, message: str) -> NoReturn:
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def port_number(text: str) -> int:
    """``--port`` value: a TCP port 1–65535 (0 would pick a random one nobody can find)."""
    try:
        port = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a port number: allowed 1–65535"
                                         ) from None
    if not 1 <= port <= 65535:
        raise argparse.ArgumentTypeError(f"{port} refused: allowed 1–65535")
    return port


def _parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="phri", description=__doc__,
                     formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)

    _sim_arguments(sub)

    plot = sub.add_parser("plot", help="figure panels (PNG) and key numbers from a recording")
    plot.add_argument("run", help="run directory, recording directory or .mcap file")
    plot.add_argument("--out", default=None, help="directory for the PNGs (default RUN/plots)")
    plot.add_argument("--scenario", default=None, help="waltz adds the waltz panels "
                      "(default: read from RUN/metrics.json, else guessed)")

    video = sub.add_parser("video", help="MP4 of a recording, rendered offscreen")
    video.add_argument("run", help="run directory, recording directory or .mcap file")
    video.add_argument("--out", default=None, help="MP4 path (default RUN/video.mp4)")
    video.add_argument("--fps", type=float, default=15.0, help="frame rate (default 15)")
    video.add_argument("--size", default="640x360", help="WIDTHxHEIGHT (default 640x360)")

    params = sub.add_parser("params", help="check or regenerate config/*.yaml")
    group = params.add_mutually_exclusive_group()
    group.add_argument("--check", action="store_true", help="(default) report problems")
    group.add_argument("--write", action="store_true",
                       help="rewrite from phri_sim.scenarios.catalogue")

    graph = sub.add_parser("graph", help="print the node graph the launch files start")
    graph.add_argument("which", choices=("sim", "real"), nargs="?", default="sim")
    graph.add_argument("--scenario", default="waltz")
    graph.add_argument("--skin-process", choices=("composed", "separate"), default="composed",
                       help="real: skin drivers and contact estimation in one process "
                            "(real.launch.py's skin_process)")
    graph.add_argument("--arm-driver", choices=("phri_rtde", "ur_robot_driver"),
                       default="phri_rtde", help="real: what drives the UR arms "
                       "(real.launch.py's arm_driver; ur_robot_driver: no phri arm bridge)")

    report = sub.add_parser("paper-report", help="run centring, sliding and whole_body; draw "
                            "Figs 6–8 panel by panel; write the paper-vs-phri page")
    report.add_argument("--out", default="runs/paper", help="directory for the figure pages "
                        "(default runs/paper)")
    report.add_argument("--seed", type=int, default=0, help="skin noise seed (default 0)")
    report.add_argument("--page", default=None, help="markdown page to write (default "
                        "OUT/paper_vs_phri.md; the repository's is docs/paper_vs_phri.md)")
    _domain_argument(report)

    layouts = sub.add_parser("layouts", help="write nominal skin layout files (real robot)")
    layouts.add_argument("directory")
    from phri_bringup.cli import ladder

    ladder.add_parser(sub, _domain_argument)
    return parser


def _sim_arguments(sub: Any) -> None:
    """The ``phri sim`` sub-command (and, beside it, ``phri followability``)."""
    sim = sub.add_parser("sim", help="run a scenario through every node, lock-step, headless")
    sim.add_argument("--scenario", default="waltz", help=SCENARIO_HELP)
    sim.add_argument("--out", default=None,
                     help="output directory (default runs/<scenario>)")
    sim.add_argument("--duration", type=float, default=None, help="simulated length [s]")
    _domain_argument(sim)
    sim.add_argument("--short", action="store_true", help="the shortened CI length")
    sim.add_argument("--seed", type=int, default=0, help="skin noise seed (same seed → same run)")
    sim.add_argument("--fault", choices=FAULT_CHOICES, default=None, help=FAULT_HELP)
    sim.add_argument("--fault-time", type=float, default=5.0, metavar="T",
                     help="sim time [s] the fault starts (default 5)")
    sim.add_argument("--fault-patch", default="", metavar="PATCH",
                     help="the patch skin_frozen_noisy / skin_half_dead / skin_gain act on "
                          "(left_upper_arm, left_forearm, right_forearm; default every patch)")
    sim.add_argument("--fault-value", type=float, default=0.0, metavar="X",
                     help="skin_gain's factor, skin_frozen_noisy's relative noise (default 0: "
                          "3 and 0.005)")
    sim.add_argument("--shove", default="", metavar="F N@T s+D s",
                     help="the partner shoves the waist into the left forearm with F newtons "
                          "from T for D seconds, e.g. 250N@20s+3s (:force = a constant force; "
                          "default :push, which falls as the partner advances; "
                          "docs/phri_sim.md, Shove)")
    sim.add_argument("--fidelity", choices=("fast", "paper"), default="fast",
                     help="fast: 5 ms physics, skin sampled at 100 Hz (default); paper: the "
                          "paper's 2 ms physics and 500 Hz skin (docs/phri_sim.md)")
    sim.add_argument("--skin-driver", action="store_true",
                     help="the real skin driver in the loop: the skin goes out as serial "
                          "protocol frames of raw counts through skin_driver's calibration, "
                          "tare and moving average")
    sim.add_argument("--params", default=None,
                     help="parameter file instead of config/<scenario>.yaml (checked before "
                          "the run starts); 'paper' with the waltz: the paper's literal set, "
                          "config/waltz_paper.yaml (the waltz_paper scenario)")
    sim.add_argument("--tempo", choices=WALTZ_TEMPOS, default="paper",
                     help="waltz tempo: paper (within Table II's limits, default) or tempo "
                          "(a real slow waltz, bar 2 s)")
    _plant_and_partner_arguments(sim)
    sim.add_argument("--record", default=None, metavar="DIR",
                     help="recording directory (default OUT/recording)")
    sim.add_argument("--no-record", action="store_true",
                     help="no recording (and so no plots, no video)")
    sim.add_argument("--skin-record-rate", type=float, default=20.0, metavar="HZ",
                     help="taxel arrays kept in the recording per second of sim time "
                          "(0 = every frame; default 20)")
    sim.add_argument("--no-plots", action="store_true", help="skip the figure panels")
    sim.add_argument("--video", dest="video", action="store_true", default=True,
                     help="render the MP4 (default)")
    sim.add_argument("--no-video", dest="video", action="store_false", help="skip the MP4")
    sim.add_argument("--foxglove", action="store_true",
                     help="serve a live Foxglove WebSocket (localhost) and run in real time")
    sim.add_argument("--port", type=port_number, default=8765,
                     help="Foxglove WebSocket port, 1–65535 (default 8765; a busy port is an "
                          "error before the run starts)")
    sim.add_argument("--realtime", type=float, default=None, metavar="FACTOR",
                     help="pace the run to FACTOR × real time (default 1 with --foxglove, "
                          "else as fast as possible)")
    _following_arguments(sub, sim)


PLANT_CHOICES = ("realistic", "ideal")
"""phri_sim.world.actuators.PLANTS (kept here so ``phri --help`` does not import the simulator;
a test checks they agree)."""
LEAD_CHOICES = ("spin_left", "spin_right", "pivot_slow", "pivot_fast", "back_away", "box")
"""phri_sim.studies.unscripted_leads.UNSCRIPTED_LEADS (a test checks they agree)."""


def positive_number(text: str) -> float:
    """``--tempo-scale`` value: a finite number > 0."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not (value > 0.0 and value < float("inf")):
        raise argparse.ArgumentTypeError(f"{value:g} refused: must be a finite number > 0")
    return value


def _plant_and_partner_arguments(sim: argparse.ArgumentParser) -> None:
    """``phri sim``'s plant and partner options (docs/phri_sim.md, "Plant", "The partner")."""
    sim.add_argument("--plant", choices=PLANT_CHOICES, default="realistic",
                     help="realistic (default): the base's command latency, acceleration and "
                          "jerk limits and velocity-loop lag, the UR16e's RTDE cycle and speedJ "
                          "ramp, the skin through the driver's 500 Hz moving average; ideal: "
                          "servos that follow every command at once")
    sim.add_argument("--tempo-scale", type=positive_number, default=1.0, metavar="K",
                     help="waltz: the routine danced K times faster (default 1)")
    sim.add_argument("--sway", type=int, default=None, metavar="SEED",
                     help="waltz: a partner with seeded postural sway, hesitations and small "
                          "deviations from the script")
    sim.add_argument("--no-partner-hand", dest="partner_hand", action="store_false",
                     default=True, help="waltz: the partner's other hand does not rest on the "
                     "robot's right forearm")
    sim.add_argument("--lead", choices=LEAD_CHOICES, default=None,
                     help="an unscripted lead from the waltz's hold instead of the waltz: "
                          "spins in place, couple turns about a pivot, backing away, a quick box")


def partner_variant(args: argparse.Namespace) -> Any:
    """``vary`` for :func:`~phri_bringup.cli.session.run_session` from ``phri sim``'s partner
    options (None: the scenario as it is)."""
    from phri_sim.scenarios.catalogue import Partner, with_partner
    from phri_sim.studies.unscripted_leads import UNSCRIPTED_LEADS, unscripted_scenario

    if args.lead is not None:
        lead = UNSCRIPTED_LEADS[args.lead]
        return lambda sc: unscripted_scenario(lead, sc)
    partner = Partner(tempo_scale=args.tempo_scale, sway=args.sway, hand=args.partner_hand)
    if partner == Partner():
        return None
    return lambda sc: with_partner(sc, partner)


def _following_arguments(sub: Any, sim: argparse.ArgumentParser) -> None:
    """``phri sim --baseline / --no-baseline`` and the ``phri followability`` sub-command."""
    sim.add_argument("--baseline", dest="baseline", action="store_true", default=None,
                     help="also run the scenario with a motionless robot (zero commands) and "
                          "print its following metrics beside the run's (default: waltz only)")
    sim.add_argument("--no-baseline", dest="baseline", action="store_false",
                     help="no motionless baseline")
    follow = sub.add_parser("followability", help="the followability map: fastest lead "
                            "followed per direction and turn (polar PNG + JSON)")
    follow.add_argument("--out", default="runs/followability", help="output directory")
    follow.add_argument("--short", action="store_true",
                        help="CI form: two speeds per direction, 0.15 m / 30° leads")
    follow.add_argument("--seed", type=int, default=0, help="skin noise seed")
    follow.add_argument("--motionless", action="store_true",
                        help="the map of a motionless robot (zero-command stub)")
    follow.add_argument("--tempo", action="store_true",
                        help="from the waltz_tempo hold: its controller set (per-axis "
                             "velocity_limits at the robot's own)")
    follow.add_argument("--plant", choices=PLANT_CHOICES, default="ideal",
                        help="ideal (default) or realistic plant (as phri sim --plant)")
    _domain_argument(follow)


def _domain_argument(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--ros-domain-id", type=int, default=None, metavar="N",
                        help="ROS domain of the run's nodes, 0…232 (default: $ROS_DOMAIN_ID if "
                             "set, else a private one, localhost only; phri_common.ros_domain)")


def _enter_domain(args: argparse.Namespace) -> int:
    """Apply the run's ROS domain (:func:`phri_common.ros_domain.run_domain`) to this process's
    environment, before any rclpy.init; returns it."""
    from phri_common.ros_domain import run_domain

    domain, env, why = run_domain(args.ros_domain_id, os.environ)
    os.environ.update(env)
    _log(why)
    return domain


def main(argv: list[str] | None = None) -> int:
    """Entry point ``phri``."""
    args = _parser().parse_args(argv)
    from phri_bringup.cli.ladder import cmd_ladder

    handler = {"sim": cmd_sim, "plot": cmd_plot, "video": cmd_video, "params": cmd_params,
               "graph": cmd_graph, "layouts": cmd_layouts,
               "followability": cmd_followability, "ladder": cmd_ladder,
               "paper-report": cmd_paper_report}[args.command]
    try:
        code = handler(args)
    except (ValueError, FileNotFoundError) as err:
        _log(f"error: {err}")
        code = 2
    if argv is None:
        sys.exit(code)
    return code


def _progress_printer(start: float) -> Any:
    def report(t: float, total: float) -> None:
        wall = time.perf_counter() - start
        if round(t) % 5 == 0 or t >= total - 1e-6:
            _log(f"sim t = {t:5.1f} / {total:.1f} s   real-time factor {t / max(wall, 1e-9):4.2f}"
                 f"   wall {wall:5.1f} s")
    return report


def cmd_sim(args: argparse.Namespace) -> int:
    """``phri sim``: run, then plots and video from the recording. Arguments, the parameter file
    and the Foxglove port are checked before anything starts (ValueError → exit code 2)."""
    os.environ.setdefault("MUJOCO_GL", "egl")
    from phri_bringup.cli.session import StopFlag, run_session
    from phri_bringup.graph.nodes import canonical_scenario, scenario_file

    name, args.params = waltz_variant(canonical_scenario(args.scenario), args.tempo, args.params)
    check_params(name, args.params)
    vary = partner_variant(args)
    if vary is not None:
        from phri_sim.scenarios.catalogue import scenario_named

        vary(scenario_named(name))  # a partner option on a scenario that is not a waltz: exit 2
    stem = scenario_file(name) if args.lead is None else f"lead_{args.lead}"
    out = Path(args.out or f"runs/{stem}")
    record_dir = None if args.no_record else Path(args.record or out / "recording")
    video_path = out / f"{scenario_file(name)}.mp4" if record_dir is not None and args.video \
        else None
    sinks = _open_sinks(args, out, record_dir, name)
    video = _start_video(video_path, sinks)
    _enter_domain(args)
    baseline = _start_baseline(args, name)
    pace = args.realtime if args.realtime is not None else (1.0 if args.foxglove else None)
    stop = StopFlag()
    previous = {sig: signal.signal(sig, stop.set) for sig in (signal.SIGINT, signal.SIGTERM)}
    start = time.perf_counter()
    _log(f"scenario {name}: running lock-step (Ctrl-C stops cleanly) → {out}")
    runs: list[Any] = []
    try:
        result = run_session(name, _run_options(args), sinks=sinks, params_file=args.params,
                             pace=pace, progress=_progress_printer(start), stop=stop,
                             inspect=runs.append, vary=vary)
    except Exception as err:
        _log(f"run failed: {type(err).__name__}: {err}")
        _panels(sinks, draw=False)
        _cancel(baseline)
        _cancel(video)
        return 2 if isinstance(err, ValueError) else 1
    finally:
        for sig, h in previous.items():
            signal.signal(sig, h)
    run_wall = time.perf_counter() - start
    _log(f"zero velocity published at exit: {'yes' if result.zero_at_exit else 'NO'}")
    if record_dir is not None:
        _log(f"recording: {record_dir} (ros2 bag info / play {record_dir}; Foxglove/Lichtblick: "
             f"open {recording_file(record_dir)})")
    _panels(sinks, draw=not result.interrupted)
    if result.interrupted:
        _log("stopped before the end: recording closed, no metrics, plots or video")
        _cancel(baseline)
        _cancel(video)
        return 130
    metrics = dict(result.metrics)
    _report_safety(metrics)
    metrics["zero_velocity_at_exit"] = result.zero_at_exit
    metrics["seed"] = args.seed
    _following(args, name, metrics, runs, out, baseline)
    metrics["bringup"] = {"run_wall_time": run_wall,
                          **_plots(args, name, record_dir, out, _drawn_panels(sinks))}
    _finish_video(video)
    (out / "metrics.json").write_text(json.dumps(metrics, indent=2, allow_nan=True) + "\n",
                                      encoding="utf-8")
    total = time.perf_counter() - start
    _log(f"metrics: {out / 'metrics.json'}; total wall time {total:.0f} s")
    return 0


def _panels(sinks: list[Any], draw: bool) -> None:
    """Once the recording is closed: its process starts drawing the panels (``draw``; they are
    taken by :func:`_drawn_panels`) or ends without them (a stopped or failed run)."""
    for sink in sinks:
        if hasattr(sink, "start_building"):
            if draw:
                sink.start_building()
            else:
                sink.discard_built()


def _drawn_panels(sinks: list[Any]) -> Any:
    """The panels the recording process drew once the recording was closed, as
    :func:`~phri_bringup.reports.plots.make_plots` returns them (None: draw them here)."""
    return next((drawn for s in sinks if hasattr(s, "take_built")
                 for drawn in (s.take_built(),) if drawn is not None), None)


def _plots(args: argparse.Namespace, name: str, record_dir: Path | None, out: Path,
           drawn: Any = None) -> dict[str, Any]:
    """The figure panels of the recording (unless ``--no-plots`` or ``--no-record``): those
    ``drawn`` by the recording process if given, else drawn here from the recording; returns
    the panels' key numbers as ``{"plots": …}``."""
    summary: dict[str, Any] = {}
    if record_dir is not None and not args.no_plots:
        from phri_bringup.reports.plots import make_plots

        files, numbers = drawn if drawn is not None else make_plots(
            record_dir, out / "plots", scenario=name)
        summary["plots"] = numbers
        _log(f"plots: {len(files)} panels in {out / 'plots'}")
    return summary


def _start_video(path: Path | None, sinks: list[Any]) -> Any:
    """The MP4 at ``path`` rendered beside the run from what the observer hands its sinks
    (:class:`~phri_bringup.reports.video_live.LiveVideoSink`, appended to ``sinks``); None for
    no video."""
    if path is None:
        return None
    from phri_bringup.reports.video_live import LiveVideoSink

    video = LiveVideoSink(path)
    sinks.append(video)
    return video


def _finish_video(video: Any) -> None:
    """Wait for the MP4 rendered beside the run (:mod:`phri_bringup.reports.video_live`) and
    report it; a failure is reported, not raised (the run's outputs stand without a video)."""
    if video is None:
        return
    from phri_bringup.reports.video import VideoUnavailable

    t_wait = time.perf_counter()
    try:
        path = video.finish()
        _log(f"video: {path} (rendered beside the run; {time.perf_counter() - t_wait:.0f} s "
             "waited for it after the panels)")
    except VideoUnavailable as err:
        _log(f"video skipped: {err}")
    except RuntimeError as err:
        _log(f"video failed: {err}")


def _run_options(args: argparse.Namespace) -> Any:
    """``phri sim``'s :class:`~phri_sim.ros.run_options.RunOptions`."""
    from phri_sim.ros.run_options import RunOptions

    return RunOptions(duration=args.duration, short=args.short, seed=args.seed,
                      fidelity=args.fidelity, skin_driver=args.skin_driver,
                      fault=args.fault or "", fault_time=args.fault_time,
                      fault_patch=args.fault_patch, fault_value=args.fault_value,
                      shove=args.shove, plant=args.plant)


def _open_sinks(args: argparse.Namespace, out: Path, record_dir: Path | None,
                scenario: str) -> list[Any]:
    """The live view (``--foxglove``, first: a busy port stops the command before any file is
    written) and the recording sink, whose process also draws the panels of ``scenario`` once
    the recording is closed; ValueError naming the option when one cannot open."""
    from phri_bringup.observer.recording_process import BackgroundRecordingSink

    sinks: list[Any] = []
    if args.foxglove:
        live = foxglove_sink(args.port)
        sinks.append(live)
        _log(f"Foxglove live view: open {live.url} in Foxglove or Lichtblick "
             "(3D panel, display frame 'odom')")
    try:
        out.mkdir(parents=True, exist_ok=True)
        if record_dir is not None:
            from phri_bringup.reports.plots import PanelsBuilder

            panels = functools.partial(PanelsBuilder, str(out / "plots"), scenario)
            sinks.append(BackgroundRecordingSink(
                str(record_dir), skin_rate_hz=args.skin_record_rate,
                builder=None if args.no_plots else panels))
    except (OSError, ValueError) as err:
        for sink in sinks:
            sink.close()
        raise ValueError(f"--out/--record: {err}") from None
    return sinks


def _start_baseline(args: argparse.Namespace, name: str) -> Any:
    """Start the motionless baseline beside the run (:mod:`phri_bringup.cli.baseline`) for a
    scenario with following metrics (the waltz), unless ``--no-baseline``; None otherwise."""
    from phri_bringup.cli.baseline import MotionlessBaseline, Recipe

    if args.baseline is False:
        return None
    recipe = Recipe.of(name, args.params, args)
    if recipe.scenario().metrics != "waltz":  # no following metrics: nothing to compare
        return None
    _log("motionless baseline: the same scenario with a robot never commanded, beside the run")
    return MotionlessBaseline(recipe, _run_options(args))


def _cancel(job: Any) -> None:
    """Stop a job beside the run (the baseline, the video), if there is one."""
    if job is not None:
        job.cancel()


def _following(args: argparse.Namespace, name: str, metrics: dict[str, Any], runs: list[Any],
               out: Path, baseline: Any) -> None:
    """For a scenario with following metrics (the waltz): the motionless baseline started by
    :func:`_start_baseline` into ``metrics['motionless']``, the side-by-side table, and
    ``plots/following.png``."""
    from phri_bringup.reports.following_report import plot_following, side_by_side

    if "following" not in metrics:
        _cancel(baseline)
        if args.baseline:
            _log(f"--baseline: scenario {name} has no following metrics; no baseline run")
        return
    series = runs[0].metrics.following_series()
    still, still_series = None, None
    if baseline is not None:
        # The same scenario value (parameters, partner, lead) and plant, a motionless robot.
        still, still_series = baseline.result()
        metrics["motionless"] = still
    for line in side_by_side(metrics["following"],
                             None if still is None else still.get("following")):
        _log(line)
    if not args.no_plots and series is not None:
        path = plot_following(out / "plots" / "following.png", series, metrics["following"],
                              still_series)
        _log(f"following plot: {path}")


def cmd_followability(args: argparse.Namespace) -> int:
    """``phri followability``: the map (polar PNG + JSON)."""
    from phri_bringup.reports.following_report import map_lines, plot_map
    from phri_sim.studies.followability import FULL_FORM, SHORT_FORM, run_map

    _enter_domain(args)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()

    def report(lead: Any, m: dict[str, Any]) -> None:
        f = m["following"]
        _log(f"{lead.name}: band {100 * f['band_share']:.0f} %, drift "
             f"{100 * f['position_drift_max']:.1f} cm / {f['heading_drift_max_deg']:.1f}°, "
             f"pass {f['pass']['all']}  (wall {time.perf_counter() - start:.0f} s)")

    result = run_map(SHORT_FORM if args.short else FULL_FORM, seed=args.seed,
                     controller="stub" if args.motionless else "node", progress=report,
                     base="waltz_tempo" if args.tempo else "waltz", plant=args.plant)
    (out / "followability.json").write_text(json.dumps(result, indent=2) + "\n",
                                            encoding="utf-8")
    plot_map(out / "followability.png", result)
    for line in map_lines(result):
        _log(line)
    _log(f"map: {out / 'followability.json'}, {out / 'followability.png'}")
    return 0


WALTZ_TEMPOS = ("paper", "tempo")


def waltz_variant(name: str, tempo: str, params: str | None) -> tuple[str, str | None]:
    """(scenario, parameter file) for ``--tempo`` and ``--params paper``: the tempo picks
    ``waltz`` or ``waltz_tempo``; ``paper`` is the paper's literal set, the ``waltz_paper``
    scenario (the paper-tempo waltz with ``config/waltz_paper.yaml``).

    Raises:
        ValueError: ``--tempo tempo`` on a scenario that is not a waltz or with the paper's set;
            ``--params paper`` on a scenario other than ``waltz`` / ``waltz_paper``.
    """
    from phri_bringup.graph.nodes import config_file

    if tempo not in WALTZ_TEMPOS:
        raise ValueError(f"--tempo {tempo!r} refused: allowed {', '.join(WALTZ_TEMPOS)}")
    if tempo == "tempo":
        if name not in ("waltz", "waltz_tempo"):
            raise ValueError(f"--tempo tempo applies to the waltz only (the waltz_tempo "
                             f"scenario); scenario is {name!r}")
        name = "waltz_tempo"
    if params == "paper":
        if name not in ("waltz", "waltz_paper"):
            raise ValueError(f"--params paper is the paper-tempo waltz's literal set (scenario "
                             f"waltz_paper); scenario is {name!r}")
        return "waltz_paper", str(config_file("waltz_paper"))
    return name, params


def check_params(name: str, params: str | None) -> None:
    """Refuse a ``--params`` file before the run starts: missing, unreadable, a refused value,
    or written for another scenario.

    Raises:
        ValueError: the problem, naming ``--params`` and the file.
    """
    from phri_bringup.cli.session import load_sections
    from phri_bringup.graph.nodes import BRIDGE

    if params is None:
        return
    path = Path(params)
    if not path.is_file():
        raise ValueError(f"--params {params}: no such file (a parameter file like "
                         "config/<scenario>.yaml, or 'paper' with --scenario waltz)")
    try:
        sections = load_sections(name, path)
    except (OSError, ValueError) as err:
        raise ValueError(f"--params {params}: {err}") from None
    written_for = sections.get(BRIDGE, {}).get("scenario", name)
    if written_for != name:
        raise ValueError(f"--params {params}: the file is for scenario {written_for!r}, not "
                         f"{name!r} (run --scenario {written_for})")


def foxglove_sink(port: int) -> Any:
    """The Foxglove live view on ``port``.

    Raises:
        ValueError: the port cannot be opened (busy, or not allowed), naming ``--port``.
    """
    from phri_bringup.observer.foxglove import FoxgloveSink

    try:
        return FoxgloveSink(port=port)
    except OSError as err:
        why = err.strerror or str(err)
        raise ValueError(f"--port {port}: cannot listen on 127.0.0.1:{port} ({why}); is "
                         "another live view or bridge on it? choose another --port") from None
    except OverflowError as err:
        raise ValueError(f"--port {port}: {err}; allowed 1–65535") from None


def recording_file(record_dir: Path) -> Path:
    """The MCAP file of a recording directory (the first one, as rosbag2 names them)."""
    files = sorted(record_dir.glob("*.mcap"))
    return files[0] if files else record_dir


def _report_safety(metrics: dict[str, Any]) -> None:
    """Log the ISO/TS 15066 verdict and, after a fault, what the robot did."""
    iso = metrics.get("iso15066")
    if iso is not None:
        worst = max(iso["person"].items(), key=lambda kv: kv[1]["peak_force"], default=None)
        text = "within" if iso["ok"] else "EXCEEDED on " + ", ".join(
            name for name, row in {**iso["person"], **iso["robot_links"]}.items()
            if not row["ok"])
        if worst is not None:
            text += (f"; largest on the person: {worst[0]} {worst[1]['peak_force']:.1f} N peak, "
                     f"{worst[1]['sustained_force']:.1f} N held 0.5 s")
        _log(f"ISO/TS 15066 body-region limits: {text}")
    fault = metrics.get("fault")
    if fault is not None:
        _log(f"fault {fault['kind']} at {fault['fault_time']:g} s: base travel "
             f"{fault['base_travel']:.3f} m, max joint excursion "
             f"{fault['max_joint_excursion']:.3f} rad, time to stop {fault['time_to_stop']}, "
             f"time to recover {fault['time_to_recover']}")


def cmd_plot(args: argparse.Namespace) -> int:
    from phri_bringup.reports.plots import make_plots

    run = Path(args.run)
    scenario = args.scenario
    metrics = run / "metrics.json"
    if scenario is None and metrics.is_file():
        scenario = json.loads(metrics.read_text(encoding="utf-8")).get("scenario")
    out = Path(args.out) if args.out else (run if run.is_dir() else run.parent) / "plots"
    files, numbers = make_plots(run, out, scenario=scenario)
    if numbers.get("scenario") == "waltz":
        from phri_bringup.reports.following_report import replot_following

        files.append(replot_following(run, out / "following.png"))
    for f in files:
        print(f)
    print(json.dumps(numbers, indent=2))
    return 0


def cmd_video(args: argparse.Namespace) -> int:
    os.environ.setdefault("MUJOCO_GL", "egl")
    from phri_bringup.reports.video import VideoOptions, VideoUnavailable, render_video

    run = Path(args.run)
    width, height = (int(x) for x in args.size.lower().split("x"))
    out = Path(args.out) if args.out else (run if run.is_dir() else run.parent) / "video.mp4"
    try:
        print(render_video(run, out, VideoOptions(width=width, height=height, fps=args.fps),
                           workers=os.cpu_count() or 1))
    except VideoUnavailable as err:
        _log(f"video skipped: {err}")
        return 3
    return 0


def cmd_params(args: argparse.Namespace) -> int:
    import phri_bringup.graph.parameter_files as params

    if args.write:
        for path in params.write_files():
            print(path)
        return 0
    problems = params.check_files()
    for p in problems:
        print(p)
    if not problems:
        print("parameter files agree with the paper's values and the nodes' declarations")
    return 1 if problems else 0


def cmd_graph(args: argparse.Namespace) -> int:
    from phri_bringup.graph.nodes import real_graph, sim_graph

    nodes = sim_graph(args.scenario) if args.which == "sim" else \
        real_graph(skin_process=args.skin_process, arm_driver=args.arm_driver)
    for spec in nodes:
        indent = ""
        if spec.nodes:
            print(f"process {spec.package}/{spec.executable} {' '.join(spec.arguments)}:")
            indent = "    "
        for n in spec.nodes or (spec,):
            ns = f"/{n.namespace}" if n.namespace else ""
            files = ", ".join(f if "/" in f else f"config/{f}.yaml"
                              for f in n.parameter_files) or "-"
            print(f"{indent}{ns}/{n.name}: {n.package}/{n.executable}  params: {files} "
                  f"{n.parameters or ''}{'  [in-process in phri sim]' if n.in_process else ''}")
    return 0


def cmd_layouts(args: argparse.Namespace) -> int:
    from phri_description.description import robot_description
    from phri_sim.world.skin_footprint import layout_for_patch
    from skin_driver.layout import save_layout

    out = Path(args.directory)
    out.mkdir(parents=True, exist_ok=True)
    for patch in robot_description().patches:
        path = out / f"{patch.name}.yaml"
        save_layout(layout_for_patch(patch), path)
        print(path)
    return 0


def cmd_paper_report(args: argparse.Namespace) -> int:
    """``phri paper-report``: Figs 6–8 pages and the paper-vs-phri page, in the run's ROS
    domain (private by default: an in-process run must not hear other ROS processes)."""
    import rclpy
    from rclpy.context import Context

    from phri_bringup.reports.paper_figures import paper_report

    out = Path(args.out)
    page = Path(args.page) if args.page else out / "paper_vs_phri.md"
    domain = _enter_domain(args)
    context = Context()
    rclpy.init(context=context, domain_id=domain)
    try:
        files, text, checks = paper_report(out, seed=args.seed, context=context)
    finally:
        context.try_shutdown()
    page.parent.mkdir(parents=True, exist_ok=True)
    page.write_text(text, encoding="utf-8")
    for f in [*files, page]:
        print(f)
    verdicts = [c.verdict for c in checks]
    _log(f"{verdicts.count('yes')} reproduced, {verdicts.count('partly')} partly, "
         f"{verdicts.count('no')} not, {verdicts.count('info')} informational")
    return 0


if __name__ == "__main__":
    main()

