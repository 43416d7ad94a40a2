"""The video's pure parts: arm/leg IK, stepping feet, the smoothed couple camera, the overlay and
the pixel-change measure (no rendering)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from phri_bringup.reports.video import changing_pixel_share
from phri_bringup.reports.video_camera import (
    CameraRig,
    SmoothCamera,
    View,
    couple_view,
    wrap_degrees,
)
from phri_bringup.reports.video_figure import DIMS, Feet, bones, skeleton, two_link_ik
from phri_bringup.reports.video_overlay import draw_overlay, overlay_lines


def _rng() -> np.random.Generator:
    return np.random.default_rng(14)


# -- two-link IK ---------------------------------------------------------------------------------
def test_ik_reaches_reachable_targets_with_bone_lengths_kept() -> None:
    rng = _rng()
    l1, l2 = DIMS.upper_arm, DIMS.forearm
    for _ in range(200):
        root = rng.uniform(-1.0, 1.0, 3)
        direction = rng.normal(size=3)
        direction /= np.linalg.norm(direction)
        target = root + direction * rng.uniform(abs(l1 - l2) + 0.01, l1 + l2 - 0.01)
        pole = rng.normal(size=3)
        mid, end = two_link_ik(root, target, l1, l2, pole)
        assert np.linalg.norm(end - target) < 1e-9
        assert np.linalg.norm(mid - root) == pytest.approx(l1, abs=1e-9)
        assert np.linalg.norm(end - mid) == pytest.approx(l2, abs=1e-9)
        # the elbow bends towards the pole: positive component along it (off the chain axis)
        u = (target - root) / np.linalg.norm(target - root)
        w = pole - np.dot(pole, u) * u
        assert np.dot(mid - root, w) > 0.0


def test_ik_out_of_reach_points_straight_at_target_and_keeps_lengths() -> None:
    root, target = np.zeros(3), np.array([2.0, 0.0, 0.0])
    mid, end = two_link_ik(root, target, 0.3, 0.28, np.array([0.0, 0.0, -1.0]))
    assert end == pytest.approx([0.58, 0.0, 0.0])
    assert mid == pytest.approx([0.3, 0.0, 0.0])


def test_ik_elbow_down_when_pole_points_down() -> None:
    shoulder = np.array([0.0, 0.0, 1.5])
    hand = np.array([0.4, 0.0, 1.5])
    mid, _ = two_link_ik(shoulder, hand, 0.3, 0.28, np.array([0.0, 0.0, -1.0]))
    assert mid[2] < 1.5 - 0.1


def test_skeleton_arm_reaches_a_recorded_hand_and_holds_a_parked_one() -> None:
    torso = np.array([1.0, 0.0, 1.0])
    feet = [(np.array([1.0, 0.1, DIMS.ankle_height]), 0.0),
            (np.array([1.0, -0.1, DIMS.ankle_height]), 0.0)]
    near = torso + np.array([0.35, 0.25, 0.3])  # within reach of the left shoulder (yaw 0)
    parked = np.array([5.0, 5.0, 0.9])
    sk = skeleton(torso, 0.0, (near, parked), feet)
    j = sk.joints
    assert np.linalg.norm(j["left_wrist"] - near) < 1e-6
    assert np.linalg.norm(j["right_wrist"] - parked) > 3.0  # hold pose, not a 5 m arm
    for side in ("left", "right"):
        assert np.linalg.norm(j[f"{side}_elbow"] - j[f"{side}_shoulder"]) == pytest.approx(
            DIMS.upper_arm)
        assert np.linalg.norm(j[f"{side}_wrist"] - j[f"{side}_elbow"]) == pytest.approx(
            DIMS.forearm)
        assert np.linalg.norm(j[f"{side}_knee"] - j[f"{side}_hip"]) == pytest.approx(DIMS.thigh)
    assert j["head"][2] > j["neck"][2] > torso[2] > j["left_knee"][2] > j["left_ankle"][2]
    assert j["left_shoulder"][1] > j["right_shoulder"][1]  # facing +x: left is +y
    assert j["nose"][0] > j["head"][0]  # the face looks where the figure faces
    assert all(r > 0.0 for _, _, r in bones(sk))


# -- stepping feet ---------------------------------------------------------------------------------
def _walk(feet: Feet, path: list[tuple[float, np.ndarray, float]]) -> list[list[np.ndarray]]:
    out = []
    for t, xy, yaw in path:
        out.append([pose[0] for pose in feet.update(t, xy, yaw)])
    return out


def test_static_hips_never_step_and_feet_stay_under_the_hips() -> None:
    feet = Feet()
    poses = _walk(feet, [(0.04 * i, np.array([0.3, -0.2]), 0.5) for i in range(250)])
    assert feet.steps == 0
    assert np.ptp(np.array(poses), axis=0).max() == 0.0
    left, right = poses[-1]
    assert np.linalg.norm(left[:2] - right[:2]) == pytest.approx(2 * DIMS.hip_half_width)


def test_walking_hips_step_planted_feet_do_not_slide_and_feet_keep_up() -> None:
    feet = Feet()
    speed, dt = 0.3, 0.04
    path = [(dt * i, np.array([speed * dt * i, 0.0]), 0.0) for i in range(250)]  # 3 m in 10 s
    poses = np.array(_walk(feet, path))  # frames × 2 feet × 3
    assert feet.steps >= 3.0 / (2 * feet.step_distance + speed * feet.swing_time)
    for k in range(2):
        z = poses[:, k, 2]
        grounded = np.isclose(z, DIMS.ankle_height)
        still = grounded[1:] & grounded[:-1]
        # a foot on the floor in two consecutive frames has not moved: no sliding
        moved = np.linalg.norm(np.diff(poses[:, k, :2], axis=0), axis=1)
        assert moved[still].max(initial=0.0) < 1e-12
        assert z.max() > DIMS.ankle_height + 0.03  # it lifted when stepping
        assert abs(poses[-1, k, 0] - path[-1][1][0]) < 0.35  # and kept up with the hips
    # never both feet in the air
    airborne = poses[:, :, 2] > DIMS.ankle_height + 1e-9
    assert not np.any(airborne.all(axis=1))


def test_turning_in_place_steps_and_turns_the_feet() -> None:
    feet = Feet()
    path = [(0.04 * i, np.zeros(2), min(0.04 * i, 4.0) * (-math.pi / 4)) for i in range(200)]
    out = [feet.update(t, xy, yaw) for t, xy, yaw in path]
    assert feet.steps >= 2
    final_yaws = [yaw for _, yaw in out[-1]]
    assert all(abs((y + math.pi + math.pi) % (2 * math.pi) - math.pi) < 0.3 for y in final_yaws)


def test_steps_start_at_most_once_per_beat() -> None:
    feet = Feet(beat=0.7)
    starts = []
    for i in range(300):
        before = feet.steps
        feet.update(0.02 * i, np.array([0.5 * 0.02 * i, 0.0]), 0.0)
        if feet.steps > before:
            starts.append(0.02 * i)
    assert len(starts) >= 3
    assert np.min(np.diff(starts)) >= 0.7 - 1e-9


# -- camera ----------------------------------------------------------------------------------------
def test_couple_view_looks_between_the_two_and_turns_with_the_couple() -> None:
    rig = CameraRig()
    view = couple_view(np.array([0.0, 0.0]), np.array([0.8, 0.0]), 0.0, rig)
    assert view.lookat[:2] == pytest.approx([0.4, 0.0])
    turned = couple_view(np.array([0.0, 0.0]), np.array([0.0, 0.8]), 0.0, rig)
    assert wrap_degrees(turned.azimuth - view.azimuth) == pytest.approx(90.0)
    far = couple_view(np.array([0.0, 0.0]), np.array([2.0, 0.0]), 0.0, rig)
    assert far.distance == pytest.approx(rig.distance + 1.2)


def test_smoothing_converges_without_overshoot() -> None:
    cam = SmoothCamera(tau=1.0)
    start = View(np.zeros(3), 0.0, -20.0, 3.0)
    goal = View(np.array([1.0, 0.0, 0.0]), 90.0, -20.0, 3.0)
    cam.update(start, 0.04)
    xs, az = [], []
    for _ in range(250):
        v = cam.update(goal, 0.04)
        xs.append(v.lookat[0])
        az.append(v.azimuth)
    assert max(xs) <= 1.0 + 1e-12 and max(az) <= 90.0 + 1e-9
    assert np.all(np.diff(xs) >= -1e-12)  # monotone: no ringing
    assert xs[-1] == pytest.approx(1.0, abs=1e-3)
    assert xs[12] < 0.5  # not a jump: half a second in, less than half way


def test_smoothing_attenuates_jitter() -> None:
    rng = _rng()
    cam = SmoothCamera(tau=1.5)
    out = []
    for _ in range(500):
        noisy = View(rng.normal(0.0, 0.05, 3), float(rng.normal(0.0, 5.0)), -20.0, 3.0)
        out.append(cam.update(noisy, 0.04).lookat[0])
    assert np.std(out[50:]) < 0.05 / 5


def test_azimuth_takes_the_short_way_across_180_degrees() -> None:
    cam = SmoothCamera(tau=1.0)
    cam.update(View(np.zeros(3), 175.0, -20.0, 3.0), 0.04)
    values = [cam.update(View(np.zeros(3), -175.0, -20.0, 3.0), 0.04).azimuth
              for _ in range(200)]
    assert min(values) >= 175.0 - 1e-9  # never swings back through 0°
    assert wrap_degrees(values[-1] - (-175.0)) == pytest.approx(0.0, abs=0.1)


def test_smoothing_rejects_a_non_positive_time_constant() -> None:
    with pytest.raises(ValueError, match="tau"):
        SmoothCamera(tau=0.0)


# -- overlay and pixel measure ---------------------------------------------------------------------
def test_overlay_writes_the_numbers_into_a_corner_box() -> None:
    lines = overlay_lines(12.34, 9.96, 1.0, -91.6, None, "left_forearm_link")
    assert "12.3 s" in lines[0] and "10.0 N" in lines[1] and "ψ = 1.00" in lines[1]
    assert "-92°" in lines[2] and "–" in lines[2]
    frame = np.full((576, 1024, 3), 200, dtype=np.uint8)
    out = draw_overlay(frame, lines)
    changed = np.any(out != frame, axis=-1)
    assert changed[-150:, :500].any()  # the box, bottom left
    assert not changed[:300].any() and not changed[:, 700:].any()
    assert frame.max() == 200  # the input frame is left alone


def test_changing_pixel_share_counts_pixels_that_change_within_a_second() -> None:
    static = [np.zeros((20, 30, 3), dtype=np.uint8)] * 30
    assert changing_pixel_share(static, fps=10.0) == 0.0
    moving = []
    for i in range(30):
        f = np.zeros((20, 30, 3), dtype=np.uint8)
        f[:, i:i + 3] = 255  # a bar sweeping one column per frame
        moving.append(f)
    share = changing_pixel_share(moving, fps=10.0)
    assert share == pytest.approx(6 / 30, abs=0.02)  # old and new bar positions differ


def test_one_foot_at_a_time_even_with_beats_shorter_than_a_swing() -> None:
    feet = Feet(beat=0.1, swing_time=0.4)
    path = [(0.02 * i, np.array([0.6 * 0.02 * i, 0.0]), 0.0) for i in range(300)]
    poses = np.array(_walk(feet, path))
    airborne = poses[:, :, 2] > DIMS.ankle_height + 1e-9
    assert feet.steps >= 4
    assert not np.any(airborne.all(axis=1))


# -- docs ------------------------------------------------------------------------------------------
def _video_docs() -> str:
    from pathlib import Path

    text = (Path(__file__).resolve().parents[2] / "docs" / "bringup.md").read_text()
    return text[text.index("### Video (`phri video`)"):text.index("## Recording")]


def _documented_value(doc: str, name: str) -> float:
    import re

    match = re.search(rf"`{name}` = ([−-]?\d+(?:\.\d+)?)", doc)
    assert match, f"docs/bringup.md, Video: no '`{name}` = value'"
    return float(match.group(1).replace("−", "-"))


def test_docs_give_every_camera_and_stepping_default_and_every_video_option() -> None:
    from dataclasses import fields

    from phri_bringup.reports import video

    doc = _video_docs()
    rig, feet = CameraRig(), Feet()
    for f in fields(CameraRig):
        assert _documented_value(doc, f.name) == pytest.approx(getattr(rig, f.name)), f.name
    for name in ("step_distance", "beat"):
        assert _documented_value(doc, name) == pytest.approx(getattr(feet, name)), name
    assert _documented_value(doc, "FORCE_SCALE") == pytest.approx(video.FORCE_SCALE)
    for f in fields(video.VideoOptions):
        assert f"`{f.name}`" in doc, f"VideoOptions.{f.name} is not documented"
