"""Render smoke test of the video from synthetic recorded signals: a couple that travels and turns
changes many pixels, a static one almost none, and the waist force arrow shows. Skipped where no
offscreen OpenGL is available (``MUJOCO_GL=egl`` works on the development machine)."""

from __future__ import annotations

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
