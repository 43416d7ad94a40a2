"""The video rendered beside the run (:mod:`phri_bringup.reports.video_live`) is the video of
the recording: the decimation keeps, for every frame time, each topic's latest sample at or
before it (hypothesis, any arrival pattern, any frame rate); frames rendered as the samples
arrive are those of the whole recording rendered afterwards, pixel for pixel; a cancelled
video leaves no file."""

from __future__ import annotations

import bisect
import os
import time
from pathlib import Path

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

os.environ.setdefault("MUJOCO_GL", "egl")  # before MuJoCo is imported
from test_video_render import FPS, _tracks

from phri_bringup.reports.video import FrameRenderer, VideoOptions, VideoUnavailable, frame_time
from phri_bringup.reports.video_live import (
    LAG_S,
    FrameDecimation,
    GrowingTrack,
    LiveVideo,
    LiveVideoSink,
)

TOPICS = ("/joint_states", "/odom", "/contacts/left_forearm_link")


def _latest(stamps: list[int], t: float) -> int | None:
    """Index of the latest of ``stamps`` [ns] at or before ``t`` [s] (as a frame reads it)."""
    i = bisect.bisect_right([s * 1e-9 for s in stamps], t) - 1
    return stamps[i] if i >= 0 else None


@settings(max_examples=150, deadline=None)
@example(gaps=[("/odom", 200_000_000), *[("/joint_states", 10_000_000)] * 300],
         fps=15.0, start_ns=0)  # a topic that falls silent
@given(gaps=st.lists(st.tuples(st.sampled_from(TOPICS),
                               st.integers(0, 40_000_000) | st.integers(0, 700_000_000)),
                     min_size=1, max_size=300),
       fps=st.sampled_from([5.0, 10.0, 15.0, 25.0, 100.0, 333.0]),
       start_ns=st.integers(0, 5_000_000_000))
def test_every_frame_sees_the_samples_it_would_see_in_the_whole_recording(
        gaps: list[tuple[str, int]], fps: float, start_ns: int) -> None:
    """Messages in time order (equal stamps too, topics falling silent): once a message
    :data:`LAG_S` later than a frame has been offered, what went on holds each topic's latest
    sample at or before the frame's time; at the end (flush), for every frame."""
    opts = VideoOptions(fps=fps)
    decimation = FrameDecimation(opts)
    kept: dict[str, list[int]] = {}
    everything: dict[str, list[int]] = {}
    t0, frame, stamp = start_ns * 1e-9, 0, start_ns

    def check_frames_until(horizon: float) -> int:
        i = frame
        while (t := frame_time(t0, i, opts)) <= horizon:
            for topic, stamps in everything.items():
                assert _latest(kept.get(topic, []), t) == _latest(stamps, t), (topic, i)
            i += 1
        return i

    for topic, gap in [("/joint_states", 0), *gaps]:
        stamp += gap
        everything.setdefault(topic, []).append(stamp)
        for sent in decimation.offer((topic, "t", b"", stamp)):
            kept.setdefault(sent[0], []).append(sent[3])
        frame = check_frames_until(stamp * 1e-9 - LAG_S)
    for sent in decimation.flush():
        kept.setdefault(sent[0], []).append(sent[3])
    check_frames_until(stamp * 1e-9)
    assert all(kept[topic] == sorted(kept[topic]) for topic in kept)
    assert sum(map(len, kept.values())) <= sum(map(len, everything.values()))


def test_the_decimation_drops_most_messages_of_a_100_hz_topic_at_15_fps() -> None:
    decimation = FrameDecimation(VideoOptions(fps=15.0))
    sent = [m for k in range(1000) for m in decimation.offer(("/joint_states", "t", b"",
                                                               k * 10_000_000))]
    assert 140 <= len(sent) <= 160  # 15 of 100 per second, over 10 s


def test_a_growing_track_reads_the_latest_sample_at_or_before_a_time() -> None:
    track = GrowingTrack()
    assert track.at(1.0) is None
    for t, v in ((0.0, "a"), (0.5, "b"), (0.5, "c"), (1.0, "d")):
        track.append(t, v)
    assert [track.at(t) for t in (-0.1, 0.0, 0.49, 0.5, 0.99, 1.0, 9.0)] == \
        [None, "a", "a", "c", "c", "d", "d"]


def test_frames_rendered_as_the_samples_arrive_are_those_of_the_whole_recording() -> None:
    tracks = _tracks(speed=0.3, turn_rate=0.6, force=10.0)
    opts = VideoOptions(width=320, height=180, fps=FPS)
    try:
        renderer = FrameRenderer(tracks, opts)
    except VideoUnavailable as err:
        pytest.skip(str(err))
    try:
        whole = list(renderer)
    finally:
        renderer.close()
    samples = sorted((float(t), topic, v) for topic, track in tracks.items()
                     for t, v in zip(track.t, track.v, strict=True))
    live = LiveVideo(opts)
    frames = []
    try:
        for t, topic, value in samples:
            live.add(topic, t, value)
            new = list(live.ready())
            assert all(live.renderer is not None and
                       live.renderer.time_of(live.next_frame - 1) <= t - LAG_S for _ in new)
            frames += new
        assert len(frames) < len(whole)  # the last LAG_S wait for the end
        frames += list(live.rest())
    finally:
        live.close()
    assert len(frames) == len(whole)
    assert all(np.array_equal(a, b) for a, b in zip(frames, whole, strict=True))


def test_a_cancelled_live_video_leaves_no_file_and_no_process(tmp_path: Path) -> None:
    """Cancelled while it encodes (the run was stopped): the partial file is removed."""
    from rclpy.serialization import serialize_message
    from sensor_msgs.msg import JointState

    from phri_description.description import JOINT_NAMES
    from phri_sim.scenarios.catalogue import Q_WALTZ

    out = tmp_path / "run.mp4"
    sink = LiveVideoSink(out)
    for k in range(300):  # 3 s at 100 Hz: frames up to 2.5 s are due at once
        msg = JointState(name=list(JOINT_NAMES), position=[float(q) for q in Q_WALTZ])
        msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(k * 10_000_000, 1_000_000_000)
        sink.on_message("/joint_states", "sensor_msgs/msg/JointState", serialize_message(msg),
                        k * 10_000_000)
    sink._batches._flush()  # what on_message has not handed over yet, without the end
    deadline = time.monotonic() + 120.0  # a bound against a hang, not a speed requirement
    while not out.exists() and sink._process.is_alive() and time.monotonic() < deadline:
        time.sleep(0.05)
    if not out.exists():
        sink.cancel()
        pytest.skip("no video rendered here (no offscreen OpenGL or no ffmpeg)")
    sink.cancel()
    assert not out.exists()
    assert not sink._process.is_alive()


def test_a_video_of_nothing_reports_a_failure_instead_of_hanging(tmp_path: Path) -> None:
    """Undecodable bytes on a video topic: the process reports an error; finish raises it."""
    sink = LiveVideoSink(tmp_path / "run.mp4")
    for k in range(3):
        sink.on_message("/joint_states", "sensor_msgs/msg/JointState", b"\x00\x01\x00\x00",
                        k * 100_000_000)
    with pytest.raises(RuntimeError, match=r"video .*run\.mp4"):
        sink.finish()
