"""The video's and the figure panels' readers decode the recorded messages (contact and task
states, joint states, odometry, commands, the person's poses, the simulator's true contacts)
straight from the recorded bytes: the same signals, value for
value, as the messages deserialized by rclpy and decoded by the reference functions."""

from __future__ import annotations

import dataclasses
import os
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from rclpy.serialization import serialize_message

os.environ.setdefault("MUJOCO_GL", "egl")  # before MuJoCo is imported: later tests render
from phri_bringup.observer.bag import McapRecording
from phri_bringup.reports import plots, video
from phri_common.contact import contact_to_msg
from phri_common.planar import quaternion_from_yaw
from phri_common.records import ContactState
from phri_description.description import BASE_JOINTS, JOINT_NAMES
from wholebody_controller.contact_task import N_VALUES, Phase, TaskOutput
from wholebody_controller.messages import task_state_to_msg

WAIST = "left_forearm_link"


def _messages(k: int, t_ns: int) -> list[tuple[str, str, Any]]:
    """One sample of every signal the readers take, at ``t_ns``, varying with ``k``."""
    from geometry_msgs.msg import PointStamped, Pose, PoseArray, Twist, WrenchStamped
    from nav_msgs.msg import Odometry
    from sensor_msgs.msg import JointState

    sec, nanosec = divmod(t_ns, 1_000_000_000)
    js = JointState(name=list(JOINT_NAMES), position=[0.01 * k + i for i in range(15)],
                    velocity=[0.001 * k * i for i in range(15)])
    js.header.stamp.sec, js.header.stamp.nanosec = sec, nanosec
    odom = Odometry(child_frame_id="base_link")
    odom.header.stamp.sec, odom.header.stamp.nanosec = sec, nanosec
    odom.pose.pose.position.x, odom.pose.pose.position.y = 0.1 * k, -0.05 * k
    q = odom.pose.pose.orientation
    q.w, q.x, q.y, q.z = quaternion_from_yaw(0.3 * k)
    odom.twist.twist.linear.x, odom.twist.twist.angular.z = 0.2, 0.01 * k
    poses = PoseArray(poses=[Pose() for _ in range(3)])
    poses.header.stamp.sec, poses.header.stamp.nanosec = sec, nanosec
    poses.poses[0].position.x = 0.5 + 0.01 * k
    contact = ContactState(WAIST, t_ns, k % 3 != 0, center=(0.1, 0.01 * k, 0.02),
                           force=(0.0, 5.0 + k, 0.5), torque=(0.0, 0.0, 0.001 * k))
    task = TaskOutput(link=WAIST, phase=Phase.ACTIVE, psi=0.1 * k, psi_raw=0.2, in_contact=True,
                      values=tuple(0.001 * (i + k) for i in range(N_VALUES)))
    wrench = WrenchStamped()
    wrench.header.stamp.sec, wrench.header.stamp.nanosec = sec, nanosec
    wrench.wrench.force.x, wrench.wrench.force.y, wrench.wrench.force.z = 0.1 * k, -1.0, 2.0
    centre = PointStamped()
    centre.header.stamp.sec, centre.header.stamp.nanosec = sec, nanosec
    centre.point.x, centre.point.y, centre.point.z = 0.2, 0.001 * k, -0.03
    cmd = Twist()
    cmd.linear.x, cmd.linear.y, cmd.angular.z = 0.01 * k, -0.02, 0.003 * k
    return [("/joint_states", "sensor_msgs/msg/JointState", js),
            (f"/sim/contacts/{WAIST}/wrench", "geometry_msgs/msg/WrenchStamped", wrench),
            (f"/sim/contacts/{WAIST}/center", "geometry_msgs/msg/PointStamped", centre),
            ("/cmd_vel", "geometry_msgs/msg/Twist", cmd),
            ("/odom", "nav_msgs/msg/Odometry", odom),
            ("/sim/person/poses", "geometry_msgs/msg/PoseArray", poses),
            (f"/contacts/{WAIST}", "sensor_msgs/msg/PointCloud2", contact_to_msg(contact)),
            (video.STATE_TOPIC, "sensor_msgs/msg/PointCloud2",
             task_state_to_msg(task, np.full(6, 0.01 * k), t_ns, "odom"))]


@pytest.fixture(scope="module")
def recording(tmp_path_factory: pytest.TempPathFactory) -> Path:
    directory = tmp_path_factory.mktemp("reads") / "recording"
    bag = McapRecording(directory)
    for k in range(40):
        t_ns = 1_000_000_000 + k * 10_000_000
        for topic, type_name, msg in _messages(k, t_ns):
            bag.add(topic, type_name, serialize_message(msg), t_ns)
    bag.close()
    return directory


def test_video_tracks_from_the_bytes_are_the_deserialized_ones(
        recording: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    fast = video.read_tracks(recording)
    monkeypatch.setattr(video, "_decode_cdr", lambda topic, raw: None)
    reference = video.read_tracks(recording)
    assert fast.keys() == reference.keys() and len(fast) == 5
    for topic, track in fast.items():
        assert np.array_equal(track.t, reference[topic].t), topic
        assert track.v == reference[topic].v, topic


def test_plot_series_from_the_bytes_are_the_deserialized_ones(
        recording: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    fast = plots.read_run(recording)
    monkeypatch.setattr(plots, "_add_cdr_sample", lambda topic, raw, t, rows, data: False)
    reference = plots.read_run(recording)

    def same(a: Any, b: Any) -> bool:
        if isinstance(a, plots.Series):
            return np.array_equal(a.t, b.t) and np.array_equal(a.v, b.v)
        if isinstance(a, dict):
            return a.keys() == b.keys() and all(same(a[k], b[k]) for k in a)
        return bool(a == b)

    for f in dataclasses.fields(plots.RunData):
        assert same(getattr(fast, f.name), getattr(reference, f.name)), f.name
    assert len(fast.force[WAIST].t) == 40 and len(fast.psi[WAIST].t) == 40
    assert len(fast.true_force[WAIST].t) == len(fast.true_centre[WAIST].t) == 40
    assert len(fast.cmd_vel.t) == len(fast.odom.t) == len(fast.torso.t) == 40
    assert fast.joint_names == [n for n in JOINT_NAMES if n not in BASE_JOINTS]
