"""Render smoke test of the video from synthetic recorded signals: a couple that travels and turns
changes many pixels, a static one almost none, and the waist force arrow shows. Skipped where no
offscreen OpenGL is available (``MUJOCO_GL=egl`` works on the development machine)."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from phri_bringup.reports.video import (
    FrameRenderer,
    Track,
    Tracks,
    VideoOptions,
    VideoUnavailable,
    changing_pixel_share,
    chunk_ranges,
)
from phri_common.planar import quaternion_from_yaw
from phri_common.records import ContactState
from phri_description.description import BASE_JOINTS, JOINT_NAMES
from phri_sim.scenarios.catalogue import Q_WALTZ

FPS = 10.0
SECONDS = 4.0
WAIST = "left_forearm_link"
HOLD = (0.637, 0.287)
"""Torso position in the base frame in the waltz hold (a recorded waltz's first pose) [m]."""


def _tracks(speed: float, turn_rate: float, force: float) -> Tracks:
    """A couple whose robot drives forward at ``speed`` [m/s] turning at ``turn_rate`` [rad/s]
    with the partner in the waltz hold (its waist at the left forearm, :data:`HOLD` in the base
    frame) facing it, and a waist force ``force`` [N] on the forearm."""
    times = np.arange(0.0, SECONDS + 1e-9, 0.05)
    odom, poses, joints, contacts = [], [], [], []
    arm = list(Q_WALTZ[len(BASE_JOINTS):])
    for t in times:
        yaw = turn_rate * t
        x, y = speed * t * math.cos(yaw), speed * t * math.sin(yaw)
        odom.append((x, y, yaw))
        joints.append((list(JOINT_NAMES), [x, y, yaw, *arm]))
        c, s = math.cos(yaw), math.sin(yaw)
        torso = (x + c * HOLD[0] - s * HOLD[1], y + s * HOLD[0] + c * HOLD[1], 1.06)
        poses.append([(torso, quaternion_from_yaw(yaw)),
                      ((1.4, 0.9, 0.9), (1.0, 0.0, 0.0, 0.0)),
                      ((1.4, -0.9, 0.9), (1.0, 0.0, 0.0, 0.0))])
        contacts.append(ContactState(WAIST, int(t * 1e9), force > 0.0,
                                     center=(0.18, -0.064, 0.039), force=(0.0, force, 0.0)))
    return {"/joint_states": Track(times, joints), "/odom": Track(times, odom),
            "/sim/person/poses": Track(times, poses), f"/contacts/{WAIST}": Track(times, contacts)}


def _frames(tracks: Tracks) -> list[np.ndarray]:
    try:
        renderer = FrameRenderer(tracks, VideoOptions(width=320, height=180, fps=FPS))
    except VideoUnavailable as err:
        pytest.skip(str(err))
    try:
        return list(renderer)
    finally:
        renderer.close()


def _red(frame: np.ndarray) -> int:
    r, g, b = (frame[..., i].astype(int) for i in range(3))
    return int(np.sum((r > 80) & (r > 2.5 * g) & (r > 2.5 * b)))


def test_turning_couple_changes_many_pixels_a_static_one_almost_none() -> None:
    moving = _frames(_tracks(speed=0.3, turn_rate=0.6, force=10.0))
    static = _frames(_tracks(speed=0.0, turn_rate=0.0, force=10.0))
    assert len(moving) == len(static) == int(SECONDS * FPS)
    share_moving = changing_pixel_share(moving, FPS)
    share_static = changing_pixel_share(static, FPS)
    assert share_static < 0.01, share_static  # the overlay's clock only
    # 0.44 measured; a camera that stays put while the couple drives off gives 0.16
    assert share_moving > 0.3, share_moving
    assert all(_red(f) > 0 for f in static)  # the waist force arrow is visible


def test_no_force_no_arrow() -> None:
    frames = _frames(_tracks(speed=0.0, turn_rate=0.0, force=0.0))
    assert max(_red(f) for f in frames) == 0


def test_a_chunk_rendered_on_its_own_has_the_frames_of_the_whole_video() -> None:
    """What the parallel render relies on: frames k… of a renderer that starts at frame k are
    those of the whole video (the camera's smoothing, the steps and the turn counters carried
    over), pixel for pixel."""
    tracks = _tracks(speed=0.3, turn_rate=0.6, force=10.0)
    whole = _frames(tracks)
    first = len(whole) // 2
    renderer = FrameRenderer(tracks, VideoOptions(width=320, height=180, fps=FPS))
    try:
        chunk = list(renderer.frames(first, len(whole)))
    finally:
        renderer.close()
    assert len(chunk) == len(whole) - first
    assert all(np.array_equal(a, b) for a, b in zip(chunk, whole[first:], strict=True))


@pytest.mark.parametrize(("n", "workers"), [(4662, 2), (4662, 5), (100, 8), (10, 3), (1, 1)])
def test_chunks_cover_every_frame_once_in_order(n: int, workers: int) -> None:
    chunks = chunk_ranges(n, workers)
    assert 1 <= len(chunks) <= workers
    assert chunks[0][0] == 0 and chunks[-1][1] == n
    assert all(a[1] == b[0] for a, b in itertools.pairwise(chunks))
    lengths = [b - a for a, b in chunks]
    assert max(lengths) - min(lengths) <= 1
