"""The recording written by a process of its own (phri_bringup.observer.recording_process) is
the recording the in-process sink writes: the same messages, topics, times and order, the taxel
arrays decimated by the same rule; a directory that holds other files is refused before the
process starts; the figure panels' series built while recording are those read back."""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from rclpy.serialization import serialize_message

from phri_bringup.observer.recording_process import BackgroundRecordingSink, SkinDecimation

SKIN = "/skin/left_forearm/taxels"


def _stream() -> list[tuple[str, str, bytes, int]]:
    """0.3 s of what the simulator publishes at 100 Hz: /clock, /joint_states, /odom and one
    patch's taxel arrays (the sink adds /tf, /tf_static and /robot_description)."""
    from nav_msgs.msg import Odometry
    from rosgraph_msgs.msg import Clock
    from sensor_msgs.msg import JointState, PointCloud2

    from phri_description.description import UR_JOINTS

    out = []
    for k in range(30):
        t_ns = 1_000_000_000 + k * 10_000_000
        clock = Clock()
        clock.clock.sec, clock.clock.nanosec = divmod(t_ns, 1_000_000_000)
        js = JointState()
        js.name = [f"{side}_{j}" for side in ("left", "right") for j in UR_JOINTS]
        js.position = [0.01 * k] * 12
        if k % 10:  # now and then a state without velocities (none to plot)
            js.velocity = [0.001 * k] * 12
        cloud = PointCloud2()
        cloud.header.stamp.sec, cloud.header.stamp.nanosec = divmod(t_ns, 1_000_000_000)
        cloud.data = bytes([k]) * 64
        out += [("/clock", "rosgraph_msgs/msg/Clock", serialize_message(clock), t_ns),
                ("/joint_states", "sensor_msgs/msg/JointState", serialize_message(js), t_ns),
                ("/odom", "nav_msgs/msg/Odometry", serialize_message(Odometry()), t_ns),
                (SKIN, "sensor_msgs/msg/PointCloud2", serialize_message(cloud), t_ns)]
    return out


def _read(directory: Path) -> list[tuple[str, int, bytes]]:
    from rosbags.highlevel import AnyReader

    with AnyReader([directory]) as reader:
        return [(conn.topic, stamp, bytes(raw)) for conn, stamp, raw in reader.messages()]


def _record(sink: Any, stream: list[tuple[str, str, bytes, int]]) -> None:
    for message in stream:
        sink.on_message(*message)
    sink.close()


def test_the_process_writes_the_recording_the_sink_writes(tmp_path: Path) -> None:
    from phri_bringup.observer.node import RecordingSink

    stream = _stream()  # once: CDR padding bytes differ between two serialisations
    _record(RecordingSink(str(tmp_path / "here"), skin_rate_hz=10.0), stream)
    _record(BackgroundRecordingSink(str(tmp_path / "there"), skin_rate_hz=10.0), stream)
    here, there = _read(tmp_path / "here"), _read(tmp_path / "there")
    assert here == there
    skins = [stamp for topic, stamp, _ in there if topic == SKIN]
    assert 1 < len(skins) < 30 and skins[0] == 1_000_000_000  # decimated
    assert {topic for topic, _, _ in there} >= {"/clock", "/joint_states", "/odom", "/tf",
                                                "/tf_static", "/robot_description"}


def test_a_directory_with_other_files_is_refused_before_the_process_starts(
        tmp_path: Path) -> None:
    directory = tmp_path / "recording"
    directory.mkdir()
    (directory / "notes.txt").write_text("mine", encoding="utf-8")
    with pytest.raises(ValueError, match="holds other files"):
        BackgroundRecordingSink(str(directory))
    assert (directory / "notes.txt").read_text(encoding="utf-8") == "mine"


def test_skin_decimation_keeps_the_asked_rate_per_patch() -> None:
    """``skin_rate_hz`` frames per second of a 100 Hz stream: 10 keeps every tenth frame (100 ms
    apart), 20 every fifth; a stream with a late frame keeps the next one on time. (The rule
    before kept frames half a period apart: 10 Hz recorded 20 frames per second.)"""
    keep = SkinDecimation(10.0)
    kept = [t for t in range(0, 300_000_000, 10_000_000) if keep.keep(SKIN, t)]
    assert kept == [0, 100_000_000, 200_000_000]
    twenty = SkinDecimation(20.0)
    assert [t for t in range(0, 200_000_000, 10_000_000) if twenty.keep(SKIN, t)] == [
        0, 50_000_000, 100_000_000, 150_000_000]
    assert keep.keep("/skin/right_forearm/taxels", 10_000_000)  # each patch on its own
    assert keep.keep("/odom", 10_000_000)  # only taxel arrays are decimated
    every = SkinDecimation(0.0)
    assert all(every.keep(SKIN, 0) for _ in range(3))


def test_the_series_built_while_recording_are_those_read_from_the_recording(
        tmp_path: Path) -> None:
    """With the panels' series builder: what the recording process builds from the messages it
    records equals :func:`~phri_bringup.reports.plots.read_run` of the recording it wrote."""
    from phri_bringup.reports.plots import RunBuilder, RunData, Series, read_run

    sink = BackgroundRecordingSink(str(tmp_path / "rec"), skin_rate_hz=10.0, builder=RunBuilder)
    _record(sink, _stream())
    built, read = sink.take_built(), read_run(tmp_path / "rec")
    assert isinstance(built, RunData)

    def same(a: Any, b: Any) -> bool:
        if isinstance(a, Series):
            return bool(np.array_equal(a.t, b.t) and np.array_equal(a.v, b.v))
        if isinstance(a, dict):
            return a.keys() == b.keys() and all(same(a[k], b[k]) for k in a)
        return bool(a == b)

    for f in dataclasses.fields(RunData):
        assert same(getattr(built, f.name), getattr(read, f.name)), f.name
    assert len(built.odom.t) == 30 and len(built.joint_velocity.t) == 27
    plain = BackgroundRecordingSink(str(tmp_path / "none"))
    plain.close()
    assert plain.take_built() is None


def test_the_panels_drawn_in_the_recording_process_are_those_drawn_from_the_recording(
        tmp_path: Path) -> None:
    """:class:`~phri_bringup.reports.plots.PanelsBuilder` as the builder: after ``close`` the
    recording process draws the panels (``phri sim`` meanwhile computes its metrics); their
    files and key numbers are those :func:`make_plots` draws from the recording it wrote."""
    import functools
    import json

    from phri_bringup.reports.plots import PanelsBuilder, make_plots

    drawn_dir, read_dir = tmp_path / "drawn", tmp_path / "read"
    sink = BackgroundRecordingSink(str(tmp_path / "rec"), skin_rate_hz=10.0,
                                   builder=functools.partial(PanelsBuilder, str(drawn_dir), None))
    _record(sink, _stream())
    files, numbers = sink.take_built()
    read_files, read_numbers = make_plots(tmp_path / "rec", read_dir)
    assert [f.name for f in files] == [f.name for f in read_files] and files
    assert all(f.parent == drawn_dir and f.stat().st_size > 0 for f in files)
    assert json.dumps(numbers, sort_keys=True) == json.dumps(read_numbers, sort_keys=True)


def test_a_builder_that_fails_leaves_the_recording_intact(tmp_path: Path) -> None:
    """A builder whose result raises (panels into a directory that cannot be made): ``close``
    returns once the recording is complete, :meth:`take_built` gives None (``phri sim`` then
    draws from the recording) and the recording holds every message."""
    import functools

    from phri_bringup.reports.plots import PanelsBuilder

    (tmp_path / "file").write_text("")
    sink = BackgroundRecordingSink(str(tmp_path / "rec"), skin_rate_hz=0.0,
                                   builder=functools.partial(PanelsBuilder,
                                                             str(tmp_path / "file" / "plots")))
    stream = _stream()
    _record(sink, stream)
    assert sink.take_built() is None
    recorded = _read(tmp_path / "rec")
    for topic in ("/clock", "/joint_states", "/odom", SKIN):
        assert sum(t == topic for t, _, _ in recorded) == sum(m[0] == topic for m in stream)


def test_a_discarded_build_draws_nothing_and_ends_the_process(tmp_path: Path) -> None:
    """A stopped run: after ``close``, :meth:`discard_built` ends the recording process without
    drawing (no panel is written), and the recording is complete."""
    import functools

    from phri_bringup.reports.plots import PanelsBuilder

    sink = BackgroundRecordingSink(str(tmp_path / "rec"), skin_rate_hz=10.0,
                                   builder=functools.partial(PanelsBuilder,
                                                             str(tmp_path / "plots")))
    stream = _stream()
    _record(sink, stream)
    sink.discard_built()
    assert not sink._process.is_alive() and sink._process.exitcode == 0
    assert not (tmp_path / "plots").exists()
    assert sink.take_built() is None
    assert sum(t == "/odom" for t, _, _ in _read(tmp_path / "rec")) == sum(
        m[0] == "/odom" for m in stream)
