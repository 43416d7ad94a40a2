"""``phri`` as a user runs it: a process that leaves a run directory, and stops cleanly."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from phri_bringup.cli import main

PHRI = [sys.executable, "-m", "phri_bringup.cli"]


def _session_processes(sid: int) -> list[int]:
    """Pids of live processes in session ``sid`` (Linux /proc)."""
    pids = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(fields[3]) == sid and fields[0] != "Z":
            pids.append(int(stat.parent.name))
    return pids


@pytest.mark.ros
def test_phri_sim_writes_recording_plots_video_and_metrics(tmp_path: Path) -> None:
    out = tmp_path / "run"
    proc = subprocess.run(
        [*PHRI, "sim", "--scenario", "wholebody", "--duration", "1.0", "--out", str(out)],
        capture_output=True, text=True, timeout=180, env={**os.environ, "MUJOCO_GL": "egl"},
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert "zero velocity published at exit: yes" in proc.stderr
    assert "real-time factor" in proc.stderr
    assert (out / "recording" / "metadata.yaml").is_file()
    assert len(list((out / "plots").glob("*.png"))) == 7  # 6 panels + the Fig. 8 page
    assert (out / "plots" / "fig8_wholebody.png").is_file()
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics["scenario"] == "whole_body" and metrics["zero_velocity_at_exit"] is True
    video = out / "wholebody.mp4"
    if "video skipped" not in proc.stderr:
        assert video.read_bytes()[4:8] == b"ftyp" and video.stat().st_size > 1000


@pytest.mark.ros
def test_ctrl_c_stops_with_zero_velocity_and_leaves_no_process(tmp_path: Path) -> None:
    out = tmp_path / "run"
    proc = subprocess.Popen(
        [*PHRI, "sim", "--scenario", "waltz", "--out", str(out), "--no-video"],
        stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True, start_new_session=True,
    )
    assert proc.stderr is not None
    deadline = time.monotonic() + 120
    progress = ""
    for line in proc.stderr:  # wait until it has simulated 5 s (its first progress line)
        if "sim t =" in line or time.monotonic() > deadline:
            progress = line
            break
    assert "sim t =" in progress, progress
    proc.send_signal(signal.SIGINT)
    rest = proc.stderr.read()
    code = proc.wait(timeout=60)
    assert code == 130, rest[-3000:]
    assert "zero velocity published at exit: yes" in rest
    assert _session_processes(proc.pid) == []
    from rosbags.highlevel import AnyReader

    with AnyReader([out / "recording"]) as reader:
        assert any(c.topic == "/cmd_vel" and c.msgcount > 0 for c in reader.connections)


def test_params_check_and_graph_commands(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["params", "--check"]) == 0
    assert main(["graph", "real"]) == 0
    text = capsys.readouterr().out
    assert "/left/ur_arm_bridge: phri_hardware/ur_arm_bridge_node" in text
    assert main(["sim", "--scenario", "tango", "--no-record"]) == 2


def test_layouts_command_writes_loadable_layouts(tmp_path: Path) -> None:
    from skin_driver.layout import load_layout

    assert main(["layouts", str(tmp_path)]) == 0
    layouts = {p.stem: load_layout(p) for p in tmp_path.glob("*.yaml")}
    assert set(layouts) == {"left_upper_arm", "left_forearm", "right_forearm"}
    assert layouts["left_forearm"].link == "left_forearm_link"


def test_fault_choices_are_the_simulator_s(capsys: pytest.CaptureFixture[str]) -> None:
    from phri_bringup.cli import FAULT_CHOICES
    from phri_sim.faults import FAULT_KINDS

    assert FAULT_CHOICES == FAULT_KINDS
    with pytest.raises(SystemExit):
        main(["sim", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    for kind in FAULT_KINDS:
        assert kind in text
    assert "--fault-time" in text


@pytest.mark.ros
def test_phri_sim_fault_reports_what_the_robot_did(tmp_path: Path) -> None:
    """`phri sim --fault force_spike --fault-time 5`: the spike reaches the skin stream once at
    5 s and metrics.json says what followed, with the ISO/TS 15066 block and verdict."""
    out = tmp_path / "run"
    proc = subprocess.run(
        [*PHRI, "sim", "--scenario", "waltz", "--duration", "5.5", "--fault", "force_spike",
         "--fault-time", "5", "--no-record", "--out", str(out)],
        capture_output=True, text=True, timeout=180,
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    metrics = json.loads((out / "metrics.json").read_text())
    fault = metrics["fault"]
    assert fault["kind"] == "force_spike" and fault["messages_changed"] == 1
    assert fault["first_changed_at"] == pytest.approx(5.0)
    assert fault["periods"] == pytest.approx(50, abs=2)
    assert metrics["iso15066"]["person"]["person_waist"]["region"] == "abdomen"
    assert "ISO/TS 15066 body-region limits: within" in proc.stderr
    assert "fault force_spike at 5 s" in proc.stderr
    bad = subprocess.run([*PHRI, "sim", "--fault", "skin_melted", "--no-record"],
                         capture_output=True, text=True, timeout=60)
    assert bad.returncode == 2 and "skin_melted" in bad.stderr
