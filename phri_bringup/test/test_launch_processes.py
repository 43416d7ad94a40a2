"""The launch files start exactly the graph's processes, and nothing when one is missing.

Runs ``sim.launch.py`` with ``launch`` (skipped where launch/launch_ros are absent, as in the
pip path) against a stand-in ament prefix: every executable of the graph is a shell script that
records its pid and sleeps, so the test sees which processes a launch starts and whether any
outlives it, without ROS nodes.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from phri_bringup.graph import share_dir, sim_graph

pytest.importorskip("launch")
pytest.importorskip("launch_ros")

RUN_LAUNCH = """
import sys
from launch import LaunchService
from launch.actions import IncludeLaunchDescription
from launch.launch_description_sources import PythonLaunchDescriptionSource
service = LaunchService()
service.include_launch_description(IncludeLaunchDescription(
    PythonLaunchDescriptionSource(sys.argv[1]), launch_arguments=[("scenario", "centring")]))
sys.exit(service.run())
"""


def _stand_in_prefix(root: Path, pids: Path, skip: str = "") -> Path:
    prefix = root / "prefix"
    index = prefix / "share" / "ament_index" / "resource_index" / "packages"
    index.mkdir(parents=True)
    for spec in sim_graph("centring"):
        if spec.package == skip:
            continue
        (index / spec.package).touch()
        exe = prefix / "lib" / spec.package / spec.executable
        exe.parent.mkdir(parents=True, exist_ok=True)
        exe.write_text(f"#!/bin/sh\necho $$ {spec.executable} >> {pids}\nexec sleep 60\n",
                       encoding="utf-8")
        exe.chmod(0o755)
    return prefix


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    stat = Path(f"/proc/{pid}/stat")
    return not (stat.exists() and stat.read_text().split()[2] == "Z")


def _launch(prefix: Path) -> subprocess.Popen[str]:
    env = {**os.environ, "AMENT_PREFIX_PATH": str(prefix)}
    return subprocess.Popen(
        [sys.executable, "-c", RUN_LAUNCH, str(share_dir() / "launch" / "sim.launch.py")],
        env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)


def _started(pids: Path) -> dict[int, str]:
    if not pids.exists():
        return {}
    return {int(p): exe for p, exe in (line.split() for line in pids.read_text().splitlines())}


def test_a_missing_executable_starts_nothing(tmp_path: Path) -> None:
    pids = tmp_path / "pids"
    proc = _launch(_stand_in_prefix(tmp_path, pids, skip="robot_state_publisher"))
    out, _ = proc.communicate(timeout=60)
    time.sleep(0.5)
    started = _started(pids)
    try:
        assert started == {}, f"started although the launch failed: {started}"
        assert "nothing was started" in out and "robot_state_publisher" in out, out
    finally:
        for pid in started:
            if _alive(pid):
                os.kill(pid, signal.SIGKILL)


def test_the_graph_starts_and_stops_with_the_launch(tmp_path: Path) -> None:
    pids = tmp_path / "pids"
    proc = _launch(_stand_in_prefix(tmp_path, pids))
    expected = sorted(s.executable for s in sim_graph("centring"))
    started: dict[int, str] = {}
    try:
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline and len(started) < len(expected):
            time.sleep(0.2)
            started = _started(pids)
        assert sorted(started.values()) == expected
        proc.send_signal(signal.SIGINT)
        proc.communicate(timeout=60)
        time.sleep(0.5)
        assert [exe for pid, exe in started.items() if _alive(pid)] == []
    finally:
        if proc.poll() is None:
            proc.kill()
        for pid in started:
            if _alive(pid):
                os.kill(pid, signal.SIGKILL)
