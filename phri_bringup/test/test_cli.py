"""``phri`` as a user runs it: a process that leaves a run directory, and stops cleanly."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from phri_bringup.cli.main import main

PHRI = [sys.executable, "-m", "phri_bringup.cli.main"]


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
        # Rendered beside the run: the frames of the recording rendered afterwards (in a
        # process of its own: MuJoCo picks its GL backend once per process).
        from phri_bringup.reports.video import video_frames

        subprocess.run([sys.executable, "-c", "import sys; from phri_bringup.reports.video "
                        "import render_video; render_video(sys.argv[1], sys.argv[2])",
                        str(out / "recording"), str(tmp_path / "afterwards.mp4")],
                       check=True, timeout=180, env={**os.environ, "MUJOCO_GL": "egl"})
        live, after = (list(video_frames(p)[0]) for p in (video, tmp_path / "afterwards.mp4"))
        assert len(live) == len(after) > 5
        assert all(np.array_equal(a, b) for a, b in zip(live, after, strict=True))


@pytest.mark.ros
def test_ctrl_c_stops_with_zero_velocity_and_leaves_no_process(tmp_path: Path) -> None:
    out = tmp_path / "run"
    proc = subprocess.Popen(
        [*PHRI, "sim", "--scenario", "waltz", "--out", str(out)],
        stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True, start_new_session=True,
        env={**os.environ, "MUJOCO_GL": "egl"},
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
    assert not (out / "waltz.mp4").exists()  # the video rendered beside the run is cancelled
    # The recording, baseline and video processes are joined before the command exits;
    # multiprocessing's resource tracker ends on its own when it sees the command gone, a
    # moment later.
    deadline = time.monotonic() + 5.0
    while _session_processes(proc.pid) and time.monotonic() < deadline:
        time.sleep(0.1)
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
    from phri_bringup.cli.main import FAULT_CHOICES
    from phri_sim.world.sensor_faults import FAULT_KINDS

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


def test_sim_help_lists_every_scenario(capsys: pytest.CaptureFixture[str]) -> None:
    from phri_bringup.cli.main import SCENARIO_CHOICES
    from phri_bringup.graph.nodes import SCENARIO_FILES, canonical_scenario

    assert {canonical_scenario(c) for c in SCENARIO_CHOICES} == set(SCENARIO_FILES)
    with pytest.raises(SystemExit):
        main(["sim", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    for choice in SCENARIO_CHOICES:
        assert choice in text, choice


def test_params_paper_is_the_waltz_paper_scenario() -> None:
    """README's ``phri sim --scenario waltz --params paper``: the waltz_paper scenario with
    config/waltz_paper.yaml, accepted by the same check the run makes; the combinations without
    a paper set are refused before anything starts."""
    from phri_bringup.cli.main import check_params, waltz_variant
    from phri_bringup.graph.nodes import config_file

    name, params = waltz_variant("waltz", "paper", "paper")
    assert (name, params) == ("waltz_paper", str(config_file("waltz_paper")))
    check_params(name, params)
    assert waltz_variant("waltz", "tempo", None) == ("waltz_tempo", None)
    assert waltz_variant("waltz_paper", "paper", "paper")[0] == "waltz_paper"
    for scenario, tempo in (("centring", "paper"), ("waltz", "tempo"), ("waltz_tempo", "paper")):
        with pytest.raises(ValueError, match="--params paper"):
            waltz_variant(scenario, tempo, "paper")
    with pytest.raises(ValueError, match="is for scenario 'waltz_paper'"):
        check_params("waltz", str(config_file("waltz_paper")))


def _one_line_error(args: list[str], out: Path) -> str:
    """Run ``phri ARGS --out OUT``; assert exit code 2, a single stderr line, nothing created."""
    proc = subprocess.run([*PHRI, *args, "--out", str(out)], capture_output=True, text=True,
                          timeout=120, stdin=subprocess.DEVNULL)
    lines = proc.stderr.strip().splitlines()
    assert proc.returncode == 2, proc.stderr[-2000:]
    assert len(lines) == 1 and "error:" in lines[0], proc.stderr[-2000:]
    assert not out.exists(), "a refused command must not start the run"
    return lines[0]


def test_bad_params_and_ports_are_one_line_errors_before_the_run(tmp_path: Path) -> None:
    import socket

    out = tmp_path / "run"
    line = _one_line_error(["sim", "--scenario", "centring", "--params", "nosuch"], out)
    assert "--params nosuch" in line and "no such file" in line
    broken = tmp_path / "broken.yaml"
    broken.write_text("wholebody_controller:\n  ros__parameters:\n    k_p: -5.0\n")
    assert "k_p" in _one_line_error(["sim", "--scenario", "centring", "--params", str(broken)],
                                     out)
    assert "--port" in _one_line_error(["sim", "--foxglove", "--port", "99999"], out)
    assert "--params paper" in _one_line_error(["sim", "--scenario", "sliding", "--params",
                                                "paper"], out)
    with socket.socket() as busy:  # a port someone else listens on
        busy.bind(("127.0.0.1", 0))
        busy.listen(1)
        port = busy.getsockname()[1]
        line = _one_line_error(["sim", "--scenario", "centring", "--foxglove", "--port",
                                str(port)], out)
    assert f"--port {port}" in line and "choose another --port" in line


@pytest.mark.ros
def test_readme_paper_set_command_runs(tmp_path: Path) -> None:
    """The README's and bringup.md's ``phri sim --scenario waltz --params paper`` (shortened)."""
    out = tmp_path / "run"
    proc = subprocess.run(
        [*PHRI, "sim", "--scenario", "waltz", "--params", "paper", "--duration", "1.0",
         "--no-video", "--no-plots", "--no-baseline", "--out", str(out)],
        capture_output=True, text=True, timeout=180, stdin=subprocess.DEVNULL,
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert json.loads((out / "metrics.json").read_text())["scenario"] == "waltz_paper"
