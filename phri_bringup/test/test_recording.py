"""Recording pieces: stamps read from CDR, the rosbag2 MCAP writer read back with the metadata
``ros2 bag play`` needs (per-topic offered QoS, latched /robot_description and /tf_static), the
/tf tree."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st
from rclpy.serialization import serialize_message

from phri_bringup.observer.bag import (
    McapRecording,
    clear_previous_recording,
    encode,
    find_recording,
    stamp_ns_of,
    tf_message,
)
from phri_bringup.observer.link_frames import RobotFrames, fixed_joint_edges, split_static


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


def test_a_rerun_replaces_a_recording_but_never_other_files(tmp_path: Path) -> None:
    for _ in range(2):  # the second run replaces the first (phri sim with the same --out)
        rec = McapRecording(tmp_path / "rec")
        rec.add("/clock", "rosgraph_msgs/msg/Clock", encode(
            "rosgraph_msgs/msg/Clock", {"clock": {"sec": 1, "nanosec": 0}}), 10)
        rec.close()
    assert sorted(p.name for p in (tmp_path / "rec").iterdir()) == ["metadata.yaml", "rec.mcap"]
    (tmp_path / "notes").mkdir()
    (tmp_path / "notes" / "todo.txt").write_text("keep me")
    with pytest.raises(ValueError, match="holds other files"):
        clear_previous_recording(tmp_path / "notes")
    assert (tmp_path / "notes" / "todo.txt").read_text() == "keep me"


@pytest.fixture(scope="module")
def sink_recording(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A RecordingSink fed what the simulator publishes for 0.1 s: /clock, /joint_states, /odom
    at 100 Hz (the recorder adds /tf, /tf_static and /robot_description)."""
    from nav_msgs.msg import Odometry
    from rosgraph_msgs.msg import Clock
    from sensor_msgs.msg import JointState

    from phri_bringup.observer.node import RecordingSink
    from phri_description.description import UR_JOINTS

    directory = tmp_path_factory.mktemp("sink") / "recording"
    sink = RecordingSink(str(directory), tf_rate_hz=50.0)
    for k in range(10):
        t_ns = 1_000_000_000 + k * 10_000_000
        stamp = {"sec": t_ns // 1_000_000_000, "nanosec": t_ns % 1_000_000_000}
        clock = Clock()
        clock.clock.sec, clock.clock.nanosec = stamp["sec"], stamp["nanosec"]
        sink.on_message("/clock", "rosgraph_msgs/msg/Clock", serialize_message(clock), t_ns)
        js = JointState()
        js.name = [f"{side}_{j}" for side in ("left", "right") for j in UR_JOINTS]
        js.position = [0.01 * k] * 12
        sink.on_message("/joint_states", "sensor_msgs/msg/JointState", serialize_message(js),
                        t_ns)
        sink.on_message("/odom", "nav_msgs/msg/Odometry", serialize_message(Odometry()), t_ns)
    sink.close()
    return directory


def _rosbag2_qos(profile: dict[str, object]) -> tuple[str, int, str, str]:
    """(history, depth, reliability, durability) of one offered profile, read the way rosbag2's
    metadata version 9 reads it (rosbag2_storage/qos.cpp: policy names as strings, times as
    sec/nsec); KeyError/AssertionError where rosbag2 would fail."""
    history, reliability = str(profile["history"]), str(profile["reliability"])
    durability, liveliness = str(profile["durability"]), str(profile["liveliness"])
    assert history in {"system_default", "keep_last", "keep_all"}
    assert reliability in {"system_default", "reliable", "best_effort"}
    assert durability in {"system_default", "transient_local", "volatile"}
    assert liveliness in {"system_default", "automatic", "manual_by_topic"}
    for key in ("deadline", "lifespan", "liveliness_lease_duration"):
        time = profile[key]
        assert isinstance(time, dict) and {"sec", "nsec"} <= set(time)
    assert isinstance(profile["avoid_ros_namespace_conventions"], bool)
    depth = profile["depth"]
    assert isinstance(depth, int)
    return history, depth, reliability, durability


def test_recording_has_the_metadata_ros2_bag_play_needs(sink_recording: Path) -> None:
    """metadata.yaml (version 9, storage mcap) lists every topic with its type, CDR, type hash
    and offered QoS; /robot_description and /tf_static are recorded once with the latched QoS
    (transient local, depth 1) so ``ros2 bag play`` replays them latched; the other topics are
    reliable and volatile as their publishers offer them."""
    from phri_bringup.graph.nodes import SIM_TOPICS
    from phri_bringup.observer.bag import typestore

    info = yaml.safe_load((sink_recording / "metadata.yaml").read_text())[
        "rosbag2_bagfile_information"]
    assert info["version"] == 9 and info["storage_identifier"] == "mcap"
    assert [f["path"] for f in info["files"]] == info["relative_file_paths"]
    assert all((sink_recording / f).is_file() for f in info["relative_file_paths"])
    topics = {t["topic_metadata"]["name"]: t for t in info["topics_with_message_count"]}
    assert {s.name for s in SIM_TOPICS} | {"/tf", "/tf_static", "/robot_description"} \
        == set(topics)
    for name, entry in topics.items():
        meta = entry["topic_metadata"]
        assert meta["serialization_format"] == "cdr", name
        assert meta["type_description_hash"] == typestore().hash_rihs01(meta["type"]), name
        [profile] = meta["offered_qos_profiles"]
        history, depth, reliability, durability = _rosbag2_qos(profile)
        latched = name in ("/tf_static", "/robot_description")
        assert (history, reliability) == ("keep_last", "reliable"), name
        assert durability == ("transient_local" if latched else "volatile"), name
        assert depth == (1 if latched else 100 if name == "/tf" else 10), name
    assert topics["/robot_description"]["message_count"] == 1
    assert topics["/tf_static"]["message_count"] == 1
    assert topics["/tf"]["message_count"] == 5  # 0.1 s at 50 Hz
    assert topics["/joint_states"]["message_count"] == 10


def test_recording_reads_back_latched_description_and_static_tf(sink_recording: Path) -> None:
    """What a player or reader gets back: the URDF, the fixed joints on /tf_static (every one,
    once, at the first stamp) and only the moving joints on /tf; rosbags sees the QoS; the MCAP
    channels carry the same QoS (rosbag2's MCAP storage reads it from there) and every CRC
    checks."""
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory
    from rosbags.highlevel import AnyReader
    from rosbags.interfaces import QosDurability

    from phri_bringup.graph.nodes import robot_description_urdf

    fixed = fixed_joint_edges()
    with AnyReader([sink_recording]) as reader:
        latched = {c.topic for c in reader.connections
                   if c.ext.offered_qos_profiles[0].durability == QosDurability.TRANSIENT_LOCAL}
        assert latched == {"/tf_static", "/robot_description"}
        static, moving = [], []
        wanted = [c for c in reader.connections
                  if c.topic in ("/robot_description", "/tf_static", "/tf")]
        for conn, t, raw in reader.messages(connections=wanted):
            msg = reader.deserialize(raw, conn.msgtype)
            if conn.topic == "/robot_description":
                assert msg.data == robot_description_urdf() and t == 1_000_000_000
            elif conn.topic == "/tf_static":
                static.append({(x.header.frame_id, x.child_frame_id) for x in msg.transforms})
            elif conn.topic == "/tf":
                moving.append({(x.header.frame_id, x.child_frame_id) for x in msg.transforms})
    assert static == [set(fixed)] and len(fixed) == 17
    assert moving and all(edges and not edges & fixed for edges in moving)
    mcap_file = next(sink_recording.glob("*.mcap"))
    with mcap_file.open("rb") as f:
        mcap = make_reader(f, validate_crcs=True, decoder_factories=[DecoderFactory()])
        summary = mcap.get_summary()
        assert summary is not None
        for channel in summary.channels.values():
            [profile] = yaml.safe_load(channel.metadata["offered_qos_profiles"])
            want = "transient_local" if channel.topic in latched else "volatile"
            assert _rosbag2_qos(profile)[3] == want, channel.topic
        decoded = sum(1 for _ in mcap.iter_decoded_messages())
    info = yaml.safe_load((sink_recording / "metadata.yaml").read_text())
    assert decoded == info["rosbag2_bagfile_information"]["message_count"] > 0


def test_static_and_moving_transforms_partition_the_tree() -> None:
    frames = RobotFrames()
    moving, static = split_static(frames.transforms())
    assert {(t.parent, t.child) for t in static} == fixed_joint_edges()
    assert len(moving) + len(static) == len(frames.transforms())
    assert {(t.parent, t.child) for t in moving}.isdisjoint(fixed_joint_edges())


def test_tf_tree_composes_to_the_simulator_link_poses() -> None:
    """Chaining the parent-relative transforms reproduces phri_sim's world link poses, and the
    tree is the URDF's (every joint's parent → child, nothing else), so a recording replayed
    beside robot_state_publisher gives no frame two parents."""
    import xml.etree.ElementTree as ET

    from scipy.spatial.transform import Rotation

    from phri_description.urdf_writer import urdf_path
    from phri_sim.scenarios.catalogue import Q_HOME
    from phri_sim.world.simulation import Simulation

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
