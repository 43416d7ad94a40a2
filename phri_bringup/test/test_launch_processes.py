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

from phri_bringup.graph.nodes import HARDWARE_CONFIG, PATCHES, real_graph, share_dir, sim_graph

pytest.importorskip("launch")
pytest.importorskip("launch_ros")

RUN_LAUNCH = """
import sys
from launch import LaunchService
from launch.actions import IncludeLaunchDescription
from launch.launch_description_sources import PythonLaunchDescriptionSource
service = LaunchService()
service.include_launch_description(IncludeLaunchDescription(
    PythonLaunchDescriptionSource(sys.argv[1]),
    launch_arguments=[tuple(a.split(":=", 1)) for a in sys.argv[2:]]))
sys.exit(service.run())
"""


def _stand_in_prefix(root: Path, pids: Path, skip: str = "", real: bool = False) -> Path:
    prefix = root / "prefix"
    index = prefix / "share" / "ament_index" / "resource_index" / "packages"
    index.mkdir(parents=True)
    for spec in real_graph() if real else sim_graph("centring"):
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


def _launch(prefix: Path, name: str = "sim.launch.py",
            args: tuple[str, ...] = ("scenario:=centring",)) -> subprocess.Popen[str]:
    env = {**os.environ, "AMENT_PREFIX_PATH": str(prefix)}
    return subprocess.Popen(
        [sys.executable, "-c", RUN_LAUNCH, str(share_dir() / "launch" / name), *args],
        env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)


def _finish(proc: subprocess.Popen[str], pids: Path) -> str:
    """Output of a launch expected to end by itself; killed (with what it started) if not."""
    try:
        return proc.communicate(timeout=60)[0]
    except subprocess.TimeoutExpired:
        proc.kill()
        for pid in _started(pids):
            if _alive(pid):
                os.kill(pid, signal.SIGKILL)
        return proc.communicate()[0] + "\n(launch did not end: killed)"


def _started(pids: Path) -> dict[int, str]:
    if not pids.exists():
        return {}
    return {int(p): exe for p, exe in (line.split() for line in pids.read_text().splitlines())}


def test_a_missing_executable_starts_nothing(tmp_path: Path) -> None:
    pids = tmp_path / "pids"
    proc = _launch(_stand_in_prefix(tmp_path, pids, skip="robot_state_publisher"))
    out = _finish(proc, pids)
    time.sleep(0.5)
    started = _started(pids)
    try:
        assert started == {}, f"started although the launch failed: {started}"
        assert "nothing was started" in out and "robot_state_publisher" in out, out
    finally:
        for pid in started:
            if _alive(pid):
                os.kill(pid, signal.SIGKILL)


def _assert_all_start_and_stop(proc: subprocess.Popen, pids: Path, expected: list[str]) -> None:
    """Every expected executable starts once, and Ctrl-C on the launch stops every one."""
    started: dict[int, str] = {}
    try:
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline and len(started) < len(expected):
            time.sleep(0.2)
            started = _started(pids)
        assert sorted(started.values()) == expected
        proc.send_signal(signal.SIGINT)
        proc.communicate(timeout=60)
        deadline = time.monotonic() + 60  # bounds a stalled machine only
        while any(_alive(pid) for pid in started) and time.monotonic() < deadline:
            time.sleep(0.05)
        assert [exe for pid, exe in started.items() if _alive(pid)] == []
    finally:
        if proc.poll() is None:
            proc.kill()
        for pid in started:
            if _alive(pid):
                os.kill(pid, signal.SIGKILL)


def test_the_graph_starts_and_stops_with_the_launch(tmp_path: Path) -> None:
    pids = tmp_path / "pids"
    proc = _launch(_stand_in_prefix(tmp_path, pids))
    expected = sorted(s.executable for s in sim_graph("centring"))
    _assert_all_start_and_stop(proc, pids, expected)


def test_real_launch_refuses_placeholders_and_starts_the_real_graph(tmp_path: Path) -> None:
    """With phri_hardware's shipped files (placeholders) nothing starts and the error names
    ur_arms.yaml; with edited copies and layouts every node of the real graph starts once."""
    pids = tmp_path / "pids"
    prefix = _stand_in_prefix(tmp_path, pids, real=True)
    proc = _launch(prefix, "real.launch.py", ())
    out = _finish(proc, pids)
    assert _started(pids) == {}, out
    assert "ur_arms.yaml" in out and "PLACEHOLDER" in out, out
    site, layouts = tmp_path / "site", tmp_path / "layouts"
    site.mkdir()
    layouts.mkdir()
    source = share_dir("phri_hardware") / "config"
    for name in HARDWARE_CONFIG.values():
        text = (source / name).read_text(encoding="utf-8").replace("PLACEHOLDER", "set")
        (site / name).write_text(text, encoding="utf-8")
    for patch in PATCHES:
        (layouts / f"{patch}.yaml").write_text("{}", encoding="utf-8")
    proc = _launch(prefix, "real.launch.py", (f"hardware_config:={site}",
                                               f"layout_dir:={layouts}"))
    expected = sorted(s.executable for s in real_graph())
    _assert_all_start_and_stop(proc, pids, expected)


def test_real_launch_with_ur_robot_driver_starts_no_arm_bridge(tmp_path: Path) -> None:
    """``arm_driver:=ur_robot_driver``: ur_arms.yaml may keep its placeholders (it is not read),
    and every node of the real graph starts except the two arm bridges."""
    pids = tmp_path / "pids"
    prefix = _stand_in_prefix(tmp_path, pids, real=True)
    site, layouts = tmp_path / "site", tmp_path / "layouts"
    site.mkdir()
    layouts.mkdir()
    source = share_dir("phri_hardware") / "config"
    for name in HARDWARE_CONFIG.values():
        text = (source / name).read_text(encoding="utf-8")
        if name != HARDWARE_CONFIG["ur_arm_bridge"]:
            text = text.replace("PLACEHOLDER", "set")
        (site / name).write_text(text, encoding="utf-8")
    for patch in PATCHES:
        (layouts / f"{patch}.yaml").write_text("{}", encoding="utf-8")
    proc = _launch(prefix, "real.launch.py", (f"hardware_config:={site}",
                                               f"layout_dir:={layouts}",
                                               "arm_driver:=ur_robot_driver"))
    expected = sorted(s.executable for s in real_graph(arm_driver="ur_robot_driver"))
    assert "ur_arm_bridge_node" not in expected
    _assert_all_start_and_stop(proc, pids, expected)
