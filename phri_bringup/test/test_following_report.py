"""Following report: the metrics recomputed from a recording's ground-truth topics agree with the
in-process block; the side-by-side table; ``phri followability --short`` (the CI form of the map);
the new options are in docs/bringup.md."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from phri_bringup.cli.main import _parser
from phri_bringup.reports.following_report import (
    replot_following,
    series_from_recording,
    side_by_side,
)
from phri_sim.evaluation.following_metrics import following_summary
from phri_sim.ros.motionless import MOTIONLESS
from phri_sim.scenarios.catalogue import WALTZ_LINK

DOC = Path(__file__).resolve().parents[2] / "docs" / "bringup.md"


def _flat(value: Any, prefix: str = "") -> dict[str, Any]:
    """A nested block as {path: number} (None as nan), for approximate comparison."""
    if isinstance(value, dict):
        return {k: v for key, item in value.items() for k, v in _flat(item, f"{prefix}.{key}")
                .items()}
    if isinstance(value, list):
        return {k: v for i, item in enumerate(value) for k, v in _flat(item, f"{prefix}[{i}]")
                .items()}
    return {prefix: float("nan") if value is None else value}


@pytest.mark.ros
def test_following_recomputed_from_the_recording_matches_the_run(tmp_path: Path) -> None:
    """7 s of the waltz (the first step starts at 2 s): the block rebuilt from /odom,
    /sim/person/poses and /sim/contacts/<link>/wrench equals the one the run computed (same
    samples, same numbers: not merely close)."""
    from phri_bringup.cli.session import run_session
    from phri_bringup.observer.node import RecordingSink
    from phri_sim.ros.run_options import RunOptions

    directory = tmp_path / "recording"
    result = run_session("waltz", RunOptions(duration=7.0),
                         sinks=[RecordingSink(str(directory), skin_rate_hz=1.0)])
    live = result.metrics["following"]
    series = series_from_recording(directory, WALTZ_LINK)
    assert len(series.times) >= 690
    again = following_summary(series, live["desired_force"])
    assert live["position_drift_max"] > 0.005  # the partner moved in the base frame
    for key in ("position_drift_rms", "position_drift_max", "heading_drift_max_deg",
                "force_error_rms", "band_share"):
        assert again[key] == pytest.approx(live[key], rel=1e-9, abs=1e-12), key
    assert again["travel"]["partner"] == pytest.approx(live["travel"]["partner"], rel=1e-9)
    # What the partner feels of the robot's motion: the same from the recorded twist, joint
    # velocities and commands (command topics carry no stamp: logged at their period's).
    for key in ("base_acceleration", "arm_acceleration", "force_fluctuation", "rest",
                "yaw_command_fluctuation"):
        assert _flat(again[key]) == pytest.approx(_flat(live[key]), rel=1e-9, abs=1e-12,
                                                  nan_ok=True), key
    assert again["turning_lag"] == pytest.approx(live["turning_lag"], rel=1e-9, abs=1e-12)
    assert max(live["base_acceleration"]["commanded"]["max"]) > 0.0
    png = replot_following(directory, tmp_path / "following.png")  # what `phri plot` draws
    assert png.read_bytes()[:4] == b"\x89PNG"


def test_side_by_side_puts_robot_and_motionless_in_columns() -> None:
    robot = {"band_share": 1.0, "position_drift_max": 0.043, "pass": {"all": True},
             "turning_lag": 0.54, "contact_losses": {"count": 0},
             "base_acceleration": {"commanded": {"p99": [0.4, 1.0, 0.7]}}}
    still = {"band_share": 0.2653, "position_drift_max": 0.1345, "pass": {"all": False},
             "turning_lag": None, "contact_losses": {"count": 2}}
    lines = side_by_side(robot, still)
    row = {line.split("|")[0].strip(): [c.strip() for c in line.split("|")[1:]]
           for line in lines}
    assert row["waist force in band [%]"] == ["100.00", "26.53"]
    assert row["position drift max [cm]"] == ["4.30", "13.45"]
    assert row["within the bars"] == ["yes", "NO"]
    assert row["turning lag [s]"] == ["0.54", "-"]
    assert row["cmd base accel p99, worst axis [m/s², rad/s²]"] == ["1.00", "-"]
    assert row["contact losses"] == ["0", "2"]
    assert all(line.split("|")[2].strip() == "-" for line in side_by_side(robot, None)[1:])


def test_followability_and_baseline_options_are_documented() -> None:
    text = DOC.read_text(encoding="utf-8")
    sub = next(a for a in _parser()._actions if a.dest == "command")
    follow = sub.choices["followability"]  # type: ignore[index]
    options = [o for a in follow._actions for o in a.option_strings if o.startswith("--")]
    options = [o for o in options if o != "--help"]
    assert "phri followability" in text
    missing = [o for o in (*options, "--baseline", "--no-baseline") if f"`{o}" not in text
               and f" {o}" not in text]
    assert not missing, f"options missing from docs/bringup.md: {missing}"


@pytest.mark.ros
def test_phri_followability_short_writes_the_map(tmp_path: Path) -> None:
    """The CI form: 8 headings and both turns, JSON and polar PNG with the tempo axis; on the
    ideal plant the lead away from the forearm (270°, the robot's right) at 0.05 m/s loses the
    waist today, straight ahead at 0.05 m/s is followed (on the realistic plant the present
    controller does not hold the hold: docs/phri_sim.md, "Plant")."""
    out = tmp_path / "map"
    proc = subprocess.run([sys.executable, "-m", "phri_bringup.cli.main", "followability",
                           "--short", "--plant", "ideal", "--out", str(out)],
                          capture_output=True, text=True,
                          timeout=300, env={**os.environ, "MUJOCO_GL": "egl"})
    assert proc.returncode == 0, proc.stderr[-3000:]
    result: dict[str, Any] = json.loads((out / "followability.json").read_text())
    assert [r["heading_deg"] for r in result["translate"]] == [0, 45, 90, 135, 180, 225, 270, 315]
    assert [t["direction"] for t in result["turn"]] == ["left", "right"]
    assert (out / "followability.png").read_bytes()[:4] == b"\x89PNG"
    fastest = {r["heading_deg"]: r["fastest_followed"] for r in result["translate"]}
    assert fastest[0] >= 0.05
    axis = result["tempo_axis"]
    assert result["translate"][0]["fastest_tempo_scale"] == pytest.approx(
        fastest[0] / axis["peak_speed"])
    assert result["plant"] == "ideal"
    assert result["cpu_time"] < 60.0


@pytest.mark.ros
def test_phri_sim_waltz_runs_the_motionless_baseline_beside_the_run(tmp_path: Path) -> None:
    """`phri sim` on the waltz: metrics.json holds the `motionless` run, stderr the table,
    plots/following.png the plot; the motionless robot does not move, the robot does."""
    out = tmp_path / "run"
    proc = subprocess.run([sys.executable, "-m", "phri_bringup.cli.main", "sim", "--scenario",
                           "waltz", "--duration", "6", "--no-record", "--out", str(out)],
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-3000:]
    metrics = json.loads((out / "metrics.json").read_text())
    still = metrics["motionless"]
    assert still["controller"] == MOTIONLESS
    assert still["following"]["travel"]["robot"] < 0.005 < metrics["following"]["travel"]["robot"]
    assert "| robot | motionless" in " ".join(proc.stderr.split())
    assert (out / "plots" / "following.png").read_bytes()[:4] == b"\x89PNG"
