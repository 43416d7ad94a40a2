"""Following report of a run: the side-by-side table with the motionless robot, the plots.

The motionless robot itself is :func:`phri_sim.ros.motionless.run_motionless`.

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

from pathlib import Path
from typing import Any

import numpy as np

from phri_bringup.reports.plots import figure
from phri_sim.evaluation.following_metrics import FollowingSeries, relative_pose

ARM_COMMAND_TOPICS = ("/left/forward_velocity_controller/commands",
                      "/right/forward_velocity_controller/commands")


def series_from_recording(path: str | Path, link: str) -> FollowingSeries:
    """The following series of a recording (run directory, recording directory or ``.mcap``):
    base pose and body twist from ``/odom``, partner pose = the first pose of
    ``/sim/person/poses``, force = ‖f‖ of ``/sim/contacts/<link>/wrench`` (touched: ‖f‖ > 0), on
    the header stamps the three share (one per control period); the arm joint velocities of
    ``/joint_states`` and the commands (``/cmd_vel``, both arms' command topics: no header, so
    the first one logged at each period's stamp) where the recording has them for every
    stamp."""
    from rosbags.highlevel import AnyReader

    from phri_bringup.observer.bag import find_recording

    wrench = f"/sim/contacts/{link}/wrench"
    rows: dict[str, dict[int, Any]] = {t: {} for t in (
        "/odom", "/sim/person/poses", wrench, "/joint_states", "/cmd_vel", *ARM_COMMAND_TOPICS)}
    with AnyReader([find_recording(path)]) as reader:
        wanted = [c for c in reader.connections if c.topic in rows]
        for conn, logged, raw in reader.messages(connections=wanted):
            _add_row(rows, conn, logged, raw, wrench)
    stamps = sorted(set.intersection(*(set(rows[t]) for t in ("/odom", "/sim/person/poses",
                                                              wrench))))
    if len(stamps) < 2:
        raise ValueError(f"{path}: fewer than 2 common stamps of /odom, /sim/person/poses, "
                         f"{wrench}")

    def column(topic: str) -> np.ndarray | None:
        found = rows[topic]
        if not all(s in found for s in stamps):
            return None
        return np.array([found[s] for s in stamps], dtype=np.float64)

    force = np.array([rows[wrench][s] for s in stamps])
    odom = np.array([rows["/odom"][s] for s in stamps], dtype=np.float64)
    partner = np.array([rows["/sim/person/poses"][s] for s in stamps], dtype=np.float64)
    arms = [a for a in (column(t) for t in ARM_COMMAND_TOPICS) if a is not None]
    return FollowingSeries(
        np.array(stamps) * 1e-9, odom[:, :3], partner, force, force > 0.0, twist=odom[:, 3:],
        command=column("/cmd_vel"), arm_velocity=column("/joint_states"),
        arm_command=np.hstack(arms) if len(arms) == len(ARM_COMMAND_TOPICS) else None)


def _add_row(rows: dict[str, dict[int, Any]], conn: Any, logged: int, raw: bytes,
             wrench: str) -> None:
    """One recorded message into ``rows[topic][stamp]`` (the header stamp, or for a message
    without one the time it was logged, keeping the first per stamp)."""
    from rclpy.serialization import deserialize_message

    from phri_bringup.observer.bag import ros_type
    from phri_common.planar import yaw_from_quaternion

    def pose(p: Any) -> list[float]:
        q = p.orientation
        return [p.position.x, p.position.y, yaw_from_quaternion(q.w, q.x, q.y, q.z)]

    msg = deserialize_message(raw, ros_type(conn.msgtype))
    topic = conn.topic
    if not hasattr(msg, "header"):
        values = ([msg.linear.x, msg.linear.y, msg.angular.z] if topic == "/cmd_vel"
                  else list(msg.data))
        rows[topic].setdefault(logged, values)
        return
    stamp = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec
    if topic == "/odom":
        tw = msg.twist.twist
        rows[topic][stamp] = [*pose(msg.pose.pose), tw.linear.x, tw.linear.y, tw.angular.z]
    elif topic == wrench:
        f = msg.wrench.force
        rows[topic][stamp] = float(np.linalg.norm([f.x, f.y, f.z]))
    elif topic == "/joint_states":
        rows[topic][stamp] = [v for n, v in zip(msg.name, msg.velocity, strict=True)
                              if n not in ("base_x", "base_y", "base_yaw")]
    elif msg.poses:
        rows[topic][stamp] = pose(msg.poses[0])


def replot_following(recording: str | Path, path: Path) -> Path:
    """``following.png`` of a recorded waltz from its ground-truth topics alone (no baseline:
    the recording holds one run): ``phri plot``."""
    from phri_sim.evaluation.following_metrics import following_summary
    from phri_sim.scenarios.catalogue import WALTZ_FORCE, WALTZ_LINK

    series = series_from_recording(recording, WALTZ_LINK)
    return plot_following(path, series, following_summary(series, WALTZ_FORCE))


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
    ("held_share", "waist touched [%]", 100.0),
    ("translation_lag", "translation lag [s]", 1.0),
    ("turning_lag", "turning lag [s]", 1.0),
    ("force_fluctuation.rms", "waist force > 1 Hz RMS [N]", 1.0),
    ("force_fluctuation.peak_frequency", "its peak frequency [Hz]", 1.0),
    ("command_acceleration_p99", "cmd base accel p99, worst axis [m/s², rad/s²]", 1.0),
    ("actual_acceleration_p99", "base accel p99, worst axis [m/s², rad/s²]", 1.0),
    ("base_acceleration.commanded.jerk_max", "cmd base jerk max [m/s³, rad/s³]", 1.0),
    ("arm_acceleration.actual.p99", "arm joint accel p99, worst [rad/s²]", 1.0),
    ("rest.time_to_rest_max", "time to rest after a stop [s]", 1.0),
    ("rest.speed_max", "base speed in stops, max [cm/s]", 100.0),
    ("peak_partner_force", "peak force on the partner [N]", 1.0),
    ("pass.all", "within the bars", 1.0),
)
"""Rows of the side-by-side table: (key path in the ``following`` block, label, scale)."""


def _value(block: dict[str, Any], path: str) -> Any:
    if path == "peak_partner_force":
        return max(block.get("peak_force", {}).get("person", {}).values(), default=0.0)
    if path.endswith("_acceleration_p99"):
        kind = "commanded" if path.startswith("command") else "actual"
        stats = block.get("base_acceleration", {}).get(kind)
        return None if stats is None else max(stats["p99"])
    value: Any = block
    for key in path.split("."):
        value = value.get(key) if isinstance(value, dict) else None
    if isinstance(value, list):  # per axis or joint: the worst
        return max(value, default=None)
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


def _drift(series: FollowingSeries) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(t, Δ(x, y) [m], Δφ [deg]) of the partner in the base frame from the hold start."""
    h = series.hold_start()
    rel = relative_pose(series.base, series.partner)[h:]
    dphi = np.degrees(np.angle(np.exp(1j * (rel[:, 2] - rel[0, 2]))))
    return np.asarray(series.times)[h:], rel[:, :2] - rel[0, :2], dphi


def plot_following(path: Path, robot: FollowingSeries, summary: dict[str, Any],
                   motionless: FollowingSeries | None = None) -> Path:
    """``following.png``: partner pose in the base frame (Δx, Δy, Δφ from the hold start), the
    waist force in its band, partner and robot headings, and what the partner feels of the
    robot's motion (from the series' twist and commands, where it has them): the yaw rates
    smoothed as for the turning lag, the base's commanded and actual acceleration beside the
    rated, the waist force above 1 Hz; the motionless run dashed."""
    bars = summary["bars"]
    lag = summary.get("turning_lag")
    title = (f"Following: band {100 * summary['band_share']:.0f} %, drift "
             f"{100 * summary['position_drift_max']:.1f} cm / "
             f"{summary['heading_drift_max_deg']:.1f}° max, turning lag "
             f"{'-' if lag is None else f'{lag:.2f} s'}, within the bars: "
             f"{'yes' if summary['pass']['all'] else 'NO'}")
    motion = robot.twist is not None and robot.command is not None
    fig, axes = figure(7 if motion else 4, title + (
        "\n(robot solid, motionless dashed)" if motionless is not None else ""),
        row_height=2.3)
    runs = [(robot, "-", 1.0)] + ([(motionless, "--", 0.6)] if motionless is not None else [])
    for series, style, alpha in runs:
        _pose_panels(axes[:4], series, style, alpha)
        if motion:
            _motion_panels(axes[4:], series, style, alpha)
    for sign in (-1, 1):
        if bars.get("position_drift_max") is not None:
            axes[0].axhline(sign * 100 * bars["position_drift_max"], color="k", lw=0.6, ls=":")
        axes[1].axhline(sign * bars["heading_drift_max_deg"], color="k", lw=0.6, ls=":")
    axes[2].axhspan(bars["band_low"], bars["band_high"], color="C2", alpha=0.12, label="band")
    axes[2].axhline(summary["desired_force"], color="k", lw=0.6, ls=":", label="desired")
    labels = ["partner in base\nframe, drift [cm]", "heading\ndrift [deg]", "waist force [N]",
              "heading [deg]", "yaw rate, 0.2 s\nsmoothed [rad/s]",
              "base accel. |a_xy|\n[m/s²]", "waist force\n> 1 Hz [N]"]
    for ax, label in zip(axes, labels, strict=False):
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
    axes[-1].set_xlabel("time [s]")
    if motion:
        accel = bars.get("command_acceleration_max")
        if accel is not None:
            axes[5].axhline(accel[0], color="k", lw=0.6, ls=":", label="rated")
    for ax in (axes[0], axes[2], axes[3], *(axes[4:6] if motion else ())):
        _legend(ax)
    return _save(fig, path)


def _pose_panels(axes: Any, series: FollowingSeries, style: str, alpha: float) -> None:
    """Drift of the partner in the base frame, heading drift, waist force, headings."""
    t, dxy, dphi = _drift(series)
    axes[0].plot(t, 100 * dxy[:, 0], style, color="C0", alpha=alpha, label="Δx")
    axes[0].plot(t, 100 * dxy[:, 1], style, color="C1", alpha=alpha, label="Δy")
    axes[1].plot(t, dphi, style, color="C2", alpha=alpha)
    axes[2].plot(series.times, series.force, style, color="C3", alpha=alpha)
    axes[3].plot(series.times, np.degrees(np.unwrap(series.partner[:, 2])), style,
                 color="C4", alpha=alpha, label="partner")
    axes[3].plot(series.times, np.degrees(np.unwrap(series.base[:, 2])), style,
                 color="C5", alpha=alpha, label="robot")


def _motion_panels(axes: Any, series: FollowingSeries, style: str, alpha: float) -> None:
    """Smoothed yaw rates (F7), commanded and actual planar base acceleration (F10), the waist
    force above 1 Hz (F11)."""
    from phri_sim.evaluation.partner_feel import high_pass, smoothed_rate

    t = np.asarray(series.times)
    axes[0].plot(t, smoothed_rate(t, np.unwrap(series.partner[:, 2])), style, color="C4",
                 alpha=alpha, label="partner")
    axes[0].plot(t, smoothed_rate(t, np.unwrap(series.base[:, 2])), style, color="C5",
                 alpha=alpha, label="robot")
    dt = float(t[1] - t[0])
    for values, color, label in ((series.command, "C6", "commanded"),
                                 (series.twist, "C7", "actual")):
        if values is not None:
            accel = np.linalg.norm(np.diff(np.asarray(values)[:, :2], axis=0), axis=1) / dt
            axes[1].plot(t[1:], accel, style, color=color, alpha=alpha, lw=0.7, label=label)
    axes[2].plot(t, high_pass(t, np.asarray(series.force)), style, color="C3", alpha=alpha,
                 lw=0.7)


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
    ax.set_title("lead translation [m/s] (×K: the waltz's tempo scale as fast), robot frame:\n"
                 "0° forward, 90° left = into the left forearm, 270° away from it (dots passed,"
                 " crosses failed)", fontsize=9)
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
    axis = result.get("tempo_axis")
    if axis is not None:  # the tempo axis: the waltz's tempo scale K at which it leads as fast
        speed, rate = axis["peak_speed"], axis["peak_turn_rate"]
        ax.set_yticks(ax.get_yticks())
        ax.set_yticklabels([f"{v:g} (×{v / speed:.1f})" for v in ax.get_yticks()], fontsize=7)
        twin = bx.secondary_yaxis("right", functions=(lambda w: w / rate, lambda k: k * rate))
        twin.set_ylabel("as fast as the waltz at ×K")
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

    def tempo(row: dict[str, Any]) -> str:
        scale = row.get("fastest_tempo_scale")
        return "" if scale is None else f" = the waltz at ×{scale:.1f}"

    lines = [f"heading {r['heading_deg']:5.0f}°: fastest followed {r['fastest_followed']:.3f} "
             f"m/s{tempo(r)} (tried {tried(r['cells'])})" for r in result["translate"]]
    lines += [f"turn {t['direction']:>5}: fastest followed {t['fastest_followed']:.3f} rad/s"
              f"{tempo(t)} (tried {tried(t['cells'])})" for t in result["turn"]]
    return lines
