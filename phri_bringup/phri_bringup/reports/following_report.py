"""Following report of a run: the motionless-robot baseline, the side-by-side table, the plots.

* :func:`run_motionless` runs a scenario again with the zero-command stub in place of the
  controller (the robot stands still; the partner still dances and presses) and returns its
  metrics and its :class:`~phri_sim.evaluation.following_metrics.FollowingSeries`;
* :func:`side_by_side` formats the ``following`` blocks of the run and the baseline as the table
  ``phri sim`` prints ("robot | motionless");
* :func:`plot_following` draws ``following.png`` (one per run): the partner's pose in the robot
  base frame, its drift, the waist force in its band, the headings of partner and robot;
* :func:`plot_map` draws the followability map (``phri followability``) as a polar PNG;
* :func:`series_from_recording` rebuilds the following series from a recording's ground-truth
  topics alone (``/odom``, ``/sim/person/poses``, ``/sim/contacts/<link>/wrench``), so the
  ``following`` block can be recomputed from any recording with
  :func:`phri_sim.evaluation.following_metrics.following_summary` (docs/phri_sim.md,
  "Following metrics").
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from phri_sim.evaluation.following_metrics import FollowingSeries, relative_pose

if TYPE_CHECKING:
    from phri_sim.ros.run_options import RunOptions
    from phri_sim.scenarios.catalogue import Scenario

Progress = Callable[[float, float], None]


def series_from_recording(path: str | Path, link: str) -> FollowingSeries:
    """The following series of a recording (run directory, recording directory or ``.mcap``):
    base pose from ``/odom``, partner pose = the first pose of ``/sim/person/poses``, force =
    ‖f‖ of ``/sim/contacts/<link>/wrench`` (touched: ‖f‖ > 0), on the header stamps the three
    share (one per control period)."""
    from rclpy.serialization import deserialize_message
    from rosbags.highlevel import AnyReader

    from phri_bringup.observer.bag import find_recording, ros_type
    from phri_common.planar import yaw_from_quaternion

    def pose(p: Any) -> list[float]:
        q = p.orientation
        return [p.position.x, p.position.y, yaw_from_quaternion(q.w, q.x, q.y, q.z)]

    wrench = f"/sim/contacts/{link}/wrench"
    rows: dict[str, dict[int, Any]] = {"/odom": {}, "/sim/person/poses": {}, wrench: {}}
    with AnyReader([find_recording(path)]) as reader:
        wanted = [c for c in reader.connections if c.topic in rows]
        for conn, _, raw in reader.messages(connections=wanted):
            msg = deserialize_message(raw, ros_type(conn.msgtype))
            stamp = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec
            if conn.topic == "/odom":
                rows[conn.topic][stamp] = pose(msg.pose.pose)
            elif conn.topic == wrench:
                f = msg.wrench.force
                rows[conn.topic][stamp] = float(np.linalg.norm([f.x, f.y, f.z]))
            elif msg.poses:
                rows[conn.topic][stamp] = pose(msg.poses[0])
    stamps = sorted(set.intersection(*(set(r) for r in rows.values())))
    if len(stamps) < 2:
        raise ValueError(f"{path}: fewer than 2 common stamps of {', '.join(rows)}")
    force = np.array([rows[wrench][s] for s in stamps])
    return FollowingSeries(np.array(stamps) * 1e-9, np.array([rows["/odom"][s] for s in stamps]),
                           np.array([rows["/sim/person/poses"][s] for s in stamps]), force,
                           force > 0.0)


def replot_following(recording: str | Path, path: Path) -> Path:
    """``following.png`` of a recorded waltz from its ground-truth topics alone (no baseline:
    the recording holds one run): ``phri plot``."""
    from phri_sim.evaluation.following_metrics import following_summary
    from phri_sim.scenarios.catalogue import WALTZ_FORCE, WALTZ_LINK

    series = series_from_recording(recording, WALTZ_LINK)
    return plot_following(path, series, following_summary(series, WALTZ_FORCE))


def run_motionless(scenario: Scenario, options: RunOptions | None = None,
                   progress: Progress | None = None
                   ) -> tuple[dict[str, Any], FollowingSeries | None]:
    """Metrics and following series of ``scenario`` run with ``options`` and a motionless robot
    (the zero-command stub in place of the controller)."""
    import rclpy
    from rclpy.context import Context
    from rclpy.signals import SignalHandlerOptions

    from phri_sim.ros.run_options import RunOptions
    from phri_sim.ros.runner import ScenarioRun

    context = Context()
    rclpy.init(context=context, signal_handler_options=SignalHandlerOptions.NO)
    run = None
    try:
        run = ScenarioRun(scenario, dataclasses.replace(options or RunOptions(), controller="stub"),
                          context=context, progress=progress)
        metrics = run.run()
        series = run.metrics.following_series()
    finally:
        if run is not None:
            run.close()
        context.try_shutdown()
    return metrics, series


ROWS: tuple[tuple[str, str, float], ...] = (
    ("band_share", "waist force in band [%]", 100.0),
    ("position_drift_rms", "position drift RMS [cm]", 100.0),
    ("position_drift_max", "position drift max [cm]", 100.0),
    ("heading_drift_max_deg", "heading drift max [deg]", 1.0),
    ("force_error_rms", "waist force error RMS [N]", 1.0),
    ("force_error_max", "waist force error max [N]", 1.0),
    ("contact_losses.count", "contact losses", 1.0),
    ("contact_losses.time_to_regain_max", "longest loss [s]", 1.0),
    ("turn.partner.left_deg", "partner turn left [deg]", 1.0),
    ("turn.partner.right_deg", "partner turn right [deg]", 1.0),
    ("turn.robot.left_deg", "robot turn left [deg]", 1.0),
    ("turn.robot.right_deg", "robot turn right [deg]", 1.0),
    ("travel.partner", "partner travel [m]", 1.0),
    ("travel.robot", "robot travel [m]", 1.0),
    ("lag", "lag [s]", 1.0),
    ("heading_lag", "heading lag [s]", 1.0),
    ("peak_partner_force", "peak force on the partner [N]", 1.0),
    ("pass.all", "within the bars", 1.0),
)
"""Rows of the side-by-side table: (key path in the ``following`` block, label, scale)."""


def _value(block: dict[str, Any], path: str) -> Any:
    if path == "peak_partner_force":
        return max(block.get("peak_force", {}).get("person", {}).values(), default=0.0)
    value: Any = block
    for key in path.split("."):
        value = value.get(key) if isinstance(value, dict) else None
    return value


def _cell(value: Any, scale: float) -> str:
    if value is None:
        return "-"
    if isinstance(value, bool):
        return "yes" if value else "NO"
    if isinstance(value, int):
        return str(value)
    return f"{value * scale:.2f}"


def side_by_side(robot: dict[str, Any], motionless: dict[str, Any] | None) -> list[str]:
    """Lines of the table "metric | robot | motionless" of two ``following`` blocks."""
    width = max(len(label) for _, label, _ in ROWS)
    lines = [f"{'following':<{width}} | {'robot':>10} | {'motionless':>10}"]
    for path, label, scale in ROWS:
        other = "-" if motionless is None else _cell(_value(motionless, path), scale)
        lines.append(f"{label:<{width}} | {_cell(_value(robot, path), scale):>10} | {other:>10}")
    return lines


def _figure(rows: int, title: str) -> tuple[Any, Any]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(rows, 1, figsize=(9, 2.3 * rows + 0.6), sharex=True, squeeze=False)
    fig.suptitle(title)
    return fig, axes[:, 0]


def _drift(series: FollowingSeries) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(t, Δ(x, y) [m], Δφ [deg]) of the partner in the base frame from the hold start."""
    h = series.hold_start()
    rel = relative_pose(series.base, series.partner)[h:]
    dphi = np.degrees(np.angle(np.exp(1j * (rel[:, 2] - rel[0, 2]))))
    return np.asarray(series.times)[h:], rel[:, :2] - rel[0, :2], dphi


def plot_following(path: Path, robot: FollowingSeries, summary: dict[str, Any],
                   motionless: FollowingSeries | None = None) -> Path:
    """``following.png``: partner pose in the base frame (Δx, Δy, Δφ from the hold start), the
    waist force in its band, partner and robot headings; the motionless run dashed."""
    bars = summary["bars"]
    title = (f"Following: band {100 * summary['band_share']:.0f} %, drift "
             f"{100 * summary['position_drift_max']:.1f} cm / "
             f"{summary['heading_drift_max_deg']:.1f}° max, within the bars: "
             f"{'yes' if summary['pass']['all'] else 'NO'}")
    fig, axes = _figure(4, title + ("\n(robot solid, motionless dashed)" if motionless
                                    is not None else ""))
    runs = [(robot, "-", 1.0)] + ([(motionless, "--", 0.6)] if motionless is not None else [])
    for series, style, alpha in runs:
        t, dxy, dphi = _drift(series)
        axes[0].plot(t, 100 * dxy[:, 0], style, color="C0", alpha=alpha, label="Δx")
        axes[0].plot(t, 100 * dxy[:, 1], style, color="C1", alpha=alpha, label="Δy")
        axes[1].plot(t, dphi, style, color="C2", alpha=alpha)
        axes[2].plot(series.times, series.force, style, color="C3", alpha=alpha)
        axes[3].plot(series.times, np.degrees(np.unwrap(series.partner[:, 2])), style,
                     color="C4", alpha=alpha, label="partner")
        axes[3].plot(series.times, np.degrees(np.unwrap(series.base[:, 2])), style,
                     color="C5", alpha=alpha, label="robot")
    for sign in (-1, 1):
        axes[0].axhline(sign * 100 * bars["position_drift_max"], color="k", lw=0.6, ls=":")
        axes[1].axhline(sign * bars["heading_drift_max_deg"], color="k", lw=0.6, ls=":")
    axes[2].axhspan(bars["band_low"], bars["band_high"], color="C2", alpha=0.12, label="band")
    axes[2].axhline(summary["desired_force"], color="k", lw=0.6, ls=":", label="desired")
    axes[0].set_ylabel("partner in base\nframe, drift [cm]")
    axes[1].set_ylabel("heading\ndrift [deg]")
    axes[2].set_ylabel("waist force [N]")
    axes[3].set_ylabel("heading [deg]")
    axes[3].set_xlabel("time [s]")
    for ax in axes:
        ax.grid(alpha=0.3)
    _legend(axes[0])
    _legend(axes[2])
    _legend(axes[3])
    return _save(fig, path)


def _legend(ax: Any) -> None:
    handles, labels = ax.get_legend_handles_labels()
    seen: dict[str, Any] = {}
    for label, handle in zip(labels, handles, strict=True):
        seen.setdefault(label, handle)  # the robot's (solid) line names the series
    ax.legend(seen.values(), seen.keys(), loc="upper right", fontsize=8)


def _save(fig: Any, path: Path) -> Path:
    import matplotlib.pyplot as plt

    path.parent.mkdir(parents=True, exist_ok=True)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def plot_map(path: Path, result: dict[str, Any]) -> Path:
    """Polar PNG of a followability map: the fastest translation followed per heading (robot
    frame, 0° = forward, 90° = left) and every speed tried (green passed, red failed); beside it
    the fastest turn followed each way."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig = plt.figure(figsize=(10, 5))
    ax: Any = fig.add_subplot(1, 2, 1, projection="polar")  # PolarAxes
    rows = result["translate"]
    theta = np.radians([r["heading_deg"] for r in rows] + [rows[0]["heading_deg"]])
    fastest = [r["fastest_followed"] for r in rows] + [rows[0]["fastest_followed"]]
    ax.plot(theta, fastest, "-o", color="C0", label="fastest followed")
    for r in rows:
        for c in r["cells"]:
            ax.plot(np.radians(r["heading_deg"]), c["speed"], "x" if not c["pass"]["all"]
                    else ".", color="C3" if not c["pass"]["all"] else "C2")
    ax.set_title("lead translation [m/s], robot frame: 0° forward, 90° left = into the\n"
                 "left forearm, 270° away from it (dots passed, crosses failed)", fontsize=9)
    ax.set_rlabel_position(112.5)
    ax.tick_params(axis="y", labelsize=7)
    ax.legend(loc="lower left", fontsize=8)
    bx = fig.add_subplot(1, 2, 2)
    turns = result["turn"]
    bx.bar([t["direction"] for t in turns], [t["fastest_followed"] for t in turns], color="C0")
    for i, t in enumerate(turns):
        for c in t["cells"]:
            bx.plot(i, abs(c["speed"]), "x" if not c["pass"]["all"] else ".",
                    color="C3" if not c["pass"]["all"] else "C2")
    bx.set_ylabel("turn rate [rad/s]")
    bx.set_title("fastest turn followed (x = tried and failed)", fontsize=9)
    who = "motionless robot" if result.get("controller") == "stub" else "whole-body controller"
    fig.suptitle(f"Followability map ({who}); bars: band ≥ "
                 f"{100 * result['bars']['band_share_min']:.0f} %, drift ≤ "
                 f"{100 * result['bars']['position_drift_max']:.0f} cm / "
                 f"{result['bars']['heading_drift_max_deg']:.0f}°, partner ≤ "
                 f"{result['bars']['partner_force_max']:.0f} N")
    return _save(fig, path)


def map_lines(result: dict[str, Any]) -> list[str]:
    """The map as text: one line per direction."""
    def tried(cells: list[dict[str, Any]]) -> str:
        return ", ".join(f"{abs(c['speed']):g}{'' if c['pass']['all'] else ' (fail)'}"
                         for c in cells)

    lines = [f"heading {r['heading_deg']:5.0f}°: fastest followed {r['fastest_followed']:.3f} "
             f"m/s (tried {tried(r['cells'])})" for r in result["translate"]]
    lines += [f"turn {t['direction']:>5}: fastest followed {t['fastest_followed']:.3f} rad/s "
              f"(tried {tried(t['cells'])})" for t in result["turn"]]
    return lines
