"""Recording pieces: stamps read from CDR, the MCAP writer read back, the /tf tree."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from rclpy.serialization import serialize_message

from phri_bringup.frames import RobotFrames
from phri_bringup.recording import McapRecording, encode, find_recording, stamp_ns_of, tf_message


@given(sec=st.integers(0, 2**31 - 1), nanosec=st.integers(0, 999_999_999))
@settings(max_examples=50, deadline=None)
def test_stamp_is_read_from_the_cdr_header(sec: int, nanosec: int) -> None:
    from geometry_msgs.msg import PointStamped, Twist
    from rosgraph_msgs.msg import Clock
    from sensor_msgs.msg import JointState

    js = JointState()
    js.header.stamp.sec, js.header.stamp.nanosec = sec, nanosec
    js.name = ["a"]
    expected = sec * 1_000_000_000 + nanosec
    assert stamp_ns_of("sensor_msgs/msg/JointState", serialize_message(js)) == expected
    clock = Clock()
    clock.clock.sec, clock.clock.nanosec = sec, nanosec
    assert stamp_ns_of("rosgraph_msgs/msg/Clock", serialize_message(clock)) == expected
    ps = PointStamped()
    ps.header.stamp.sec, ps.header.stamp.nanosec = sec, nanosec
    assert stamp_ns_of("geometry_msgs/msg/PointStamped", serialize_message(ps)) == expected
    assert stamp_ns_of("geometry_msgs/msg/Twist", serialize_message(Twist())) is None
    assert stamp_ns_of("sensor_msgs/msg/JointState", b"\x00\x01") is None


def test_recording_round_trip_through_rosbags(tmp_path: Path) -> None:
    from geometry_msgs.msg import Twist
    from rosbags.highlevel import AnyReader

    rec = McapRecording(tmp_path / "rec")
    sent = []
    for i in range(5):
        msg = Twist()
        msg.linear.x = 0.1 * i
        rec.add("/cmd_vel", "geometry_msgs/msg/Twist", serialize_message(msg), 1000 + i)
        sent.append(0.1 * i)
    with pytest.raises(ValueError, match="recorded as"):
        rec.add("/cmd_vel", "std_msgs/msg/String", b"", 2000)
    rec.close()
    assert find_recording(tmp_path) == tmp_path / "rec"
    with AnyReader([tmp_path / "rec"]) as reader:
        got = [(t, reader.deserialize(raw, c.msgtype).linear.x)
               for c, t, raw in reader.messages()]
        assert reader.duration == 5  # last - first + 1 [ns]
    assert got == [(1000 + i, pytest.approx(x)) for i, x in enumerate(sent)]


def test_tf_tree_composes_to_the_simulator_link_poses() -> None:
    """Chaining the parent-relative transforms reproduces phri_sim's world link poses, and the
    tree is the URDF's (every joint's parent → child, nothing else), so a recording replayed
    beside robot_state_publisher gives no frame two parents."""
    import xml.etree.ElementTree as ET

    from scipy.spatial.transform import Rotation

    from phri_description.urdf_writer import urdf_path
    from phri_sim.scenarios import Q_HOME
    from phri_sim.sim import Simulation

    rng = np.random.default_rng(0)
    sim = Simulation()
    q = np.array(Q_HOME) + rng.uniform(-0.5, 0.5, 15)
    sim.reset(q)
    frames = RobotFrames()
    frames.set_state(sim.joint_names[3:], q[3:], q[:3])
    world: dict[str, tuple[np.ndarray, np.ndarray]] = {"odom": (np.eye(3), np.zeros(3))}
    transforms = frames.transforms()
    urdf = ET.parse(urdf_path()).getroot()
    urdf_edges = {(j.find("parent").get("link"), j.find("child").get("link"))  # type: ignore[union-attr]
                  for j in urdf.iter("joint")}
    assert [(t.parent, t.child) for t in transforms if (t.parent, t.child) in urdf_edges] == \
        [(t.parent, t.child) for t in transforms]
    assert {(t.parent, t.child) for t in transforms} == urdf_edges
    assert len({t.child for t in transforms}) == len(transforms)
    for t in transforms:  # parents come before children (URDF joint order)
        rp, pp = world[t.parent]
        w, x, y, z = t.rotation
        r = Rotation.from_quat([x, y, z, w]).as_matrix()
        world[t.child] = (rp @ r, rp @ np.array(t.translation) + pp)
    for link in ("left_forearm_link", "right_wrist_3_link", "left_upper_arm_link"):
        rot, pos = sim.link_pose(link)
        assert np.allclose(world[link][0], rot, atol=1e-9)
        assert np.allclose(world[link][1], pos, atol=1e-9)
    # And the encoded TFMessage carries them.
    raw = encode("tf2_msgs/msg/TFMessage", tf_message(transforms, 5))
    assert len(raw) > 100 * len(transforms) // 2
