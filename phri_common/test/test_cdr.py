"""phri_common.cdr against rclpy's own serializer (the reference): what rclpy writes, the readers
read back field for field; what the writers write, rclpy reads back as the message built by hand;
truncated or garbage bytes give a CdrError naming the field, never another exception."""

from __future__ import annotations

import struct
from typing import Any

import numpy as np
import pytest
from geometry_msgs.msg import PointStamped, Pose, PoseArray, Twist, WrenchStamped
from hypothesis import given, settings
from hypothesis import strategies as st
from nav_msgs.msg import Odometry
from rclpy.serialization import deserialize_message, serialize_message
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray, MultiArrayDimension

from phri_common.cdr import (
    MAX_NAMES,
    CdrError,
    Float64ArrayEncoder,
    joint_state_arrays_from_cdr,
    joint_state_from_cdr,
    odometry_from_cdr,
    odometry_pose_from_cdr,
    point_stamped_to_cdr,
    pose_array_from_cdr,
    pose_array_to_cdr,
    stamped_xyz_from_cdr,
    twist_from_cdr,
    twist_to_cdr,
    wrench_stamped_to_cdr,
)
from phri_common.stamps import ns_to_stamp

RNG_SEED = 15


def random_name(rng: np.random.Generator) -> str:
    return "".join(rng.choice(list("abcdefgh_ij"), size=int(rng.integers(0, 12))))


def joint_state(rng: np.random.Generator) -> JointState:
    n = int(rng.integers(0, 14))
    msg = JointState(name=[random_name(rng) for _ in range(n)],
                     position=rng.normal(size=n).tolist())
    msg.header.frame_id = random_name(rng)
    msg.header.stamp.sec, msg.header.stamp.nanosec = int(rng.integers(0, 2**31)), 7
    if rng.random() < 0.5:  # velocities present or not: not read, must not disturb
        msg.velocity = rng.normal(size=n).tolist()
    return msg


def odometry(rng: np.random.Generator) -> Odometry:
    msg = Odometry()
    msg.header.frame_id = random_name(rng)
    msg.child_frame_id = random_name(rng)
    p, o = msg.pose.pose.position, msg.pose.pose.orientation
    p.x, p.y, p.z = rng.normal(size=3).tolist()
    o.x, o.y, o.z, o.w = rng.normal(size=4).tolist()
    msg.pose.covariance = rng.normal(size=36).tolist()
    msg.twist.twist.linear.x = 0.5
    return msg


def test_joint_states_read_as_rclpy_wrote_them() -> None:
    rng = np.random.default_rng(RNG_SEED)
    for _ in range(200):
        msg = joint_state(rng)
        decoded = joint_state_from_cdr(serialize_message(msg))
        assert decoded is not None
        assert decoded[0] == tuple(msg.name)
        assert decoded[1] == tuple(msg.position)


def test_joint_state_arrays_read_as_rclpy_wrote_them() -> None:
    """Velocities and efforts too (the controller's external-torque estimate reads them); an
    empty field reads empty."""
    rng = np.random.default_rng(RNG_SEED)
    for _ in range(200):
        msg = joint_state(rng)
        if rng.random() < 0.7:
            msg.effort = rng.normal(size=len(msg.name)).tolist()
        decoded = joint_state_arrays_from_cdr(serialize_message(msg))
        assert decoded == (tuple(msg.name), tuple(msg.position), tuple(msg.velocity),
                           tuple(msg.effort))
    assert joint_state_arrays_from_cdr(big_endian(serialize_message(joint_state(rng)))) is None


def test_odometry_pose_read_as_rclpy_wrote_it() -> None:
    rng = np.random.default_rng(RNG_SEED)
    for _ in range(200):
        msg = odometry(rng)
        p, o = msg.pose.pose.position, msg.pose.pose.orientation
        assert odometry_pose_from_cdr(serialize_message(msg)) == (p.x, p.y, p.z,
                                                                  o.x, o.y, o.z, o.w)


def test_twist_bytes_are_rclpys() -> None:
    rng = np.random.default_rng(RNG_SEED)
    for _ in range(50):
        vx, vy, wz = rng.normal(size=3).tolist()
        msg = Twist()
        msg.linear.x, msg.linear.y, msg.angular.z = vx, vy, wz
        data = twist_to_cdr(vx, vy, wz)
        assert data == serialize_message(msg)  # a Twist has no padding: byte for byte
        assert deserialize_message(data, Twist) == msg


@pytest.mark.parametrize("label_length", range(0, 10))
def test_float64_array_reads_back_as_the_message_built_by_hand(label_length: int) -> None:
    rng = np.random.default_rng(label_length)
    label = "j" * label_length  # every padding case before the float64 data
    size = int(rng.integers(1, 8))
    values = rng.normal(size=size).tolist()
    data = Float64ArrayEncoder(label, size).encode(values)
    expected = Float64MultiArray(data=values)
    expected.layout.dim = [MultiArrayDimension(label=label, size=size, stride=size)]
    assert deserialize_message(data, Float64MultiArray) == expected
    assert len(data) == len(serialize_message(expected))


def test_float64_array_refuses_a_wrong_count_and_bad_arguments() -> None:
    encoder = Float64ArrayEncoder("a,b", 2)
    with pytest.raises(ValueError, match="values: 3 numbers, expected 2"):
        encoder.encode([1.0, 2.0, 3.0])
    with pytest.raises(ValueError, match="size = 0"):
        Float64ArrayEncoder("a", 0)
    with pytest.raises(ValueError, match="label"):
        Float64ArrayEncoder("a\x00b", 1)


def big_endian(data: bytes) -> bytes:
    return b"\x00\x00" + data[2:]


def test_big_endian_bytes_are_left_to_rclpy() -> None:
    rng = np.random.default_rng(RNG_SEED)
    assert joint_state_from_cdr(big_endian(serialize_message(joint_state(rng)))) is None
    assert odometry_pose_from_cdr(big_endian(serialize_message(odometry(rng)))) is None


def test_every_truncation_is_a_clear_error_or_the_same_answer() -> None:
    """A prefix of a message either still holds every field read (same answer) or raises
    CdrError naming a field; never IndexError, struct.error or a wrong answer."""
    rng = np.random.default_rng(RNG_SEED)
    for reader, msg in ((joint_state_from_cdr, joint_state(rng)),
                        (odometry_pose_from_cdr, odometry(rng))):
        assert_truncations_answer_or_name(reader, serialize_message(msg),
                                          ("header", "name", "position", "child_frame_id", "pose"))


def assert_truncations_answer_or_name(reader: Any, data: bytes, words: tuple[str, ...]) -> None:
    """Every prefix of ``data`` gives ``reader``'s full answer or a CdrError naming one of
    ``words``; at least one prefix is an error."""
    full = reader(data)
    errors = 0
    for end in range(2, len(data)):
        try:
            assert reader(data[:end]) == full
        except CdrError as err:
            errors += 1
            assert any(word in str(err) for word in words), str(err)
    assert errors > 0


def test_garbage_counts_are_refused_naming_the_field_and_value() -> None:
    msg = JointState(name=["a"], position=[1.0])
    data = bytearray(serialize_message(msg))
    # header: stamp (8 bytes), frame_id "" (length 1 + NUL), padded to 16; then the name count.
    struct.pack_into("<I", data, 4 + 16, 0xFFFFFFFF)
    with pytest.raises(CdrError, match=f"name: 4294967295 names, allowed at most {MAX_NAMES}"):
        joint_state_from_cdr(bytes(data))
    data = bytearray(serialize_message(msg))
    struct.pack_into("<I", data, 4 + 8, 10**6)  # frame_id length
    with pytest.raises(CdrError, match=r"joint state\.header\.frame_id: string length 1000000"):
        joint_state_from_cdr(bytes(data))
    data = bytearray(serialize_message(msg))
    struct.pack_into("<I", data, 4 + 28, 1000)  # position count
    with pytest.raises(CdrError, match="position: 1000 values do not fit"):
        joint_state_from_cdr(bytes(data))


def test_repeated_names_are_reused_only_while_their_bytes_repeat() -> None:
    """The reader reuses the last names block when the bytes are the same; a name that changes
    in its last character, or a different frame_id before the names, reads as rclpy wrote it."""
    first = JointState(name=["joint_a", "joint_b"], position=[1.0, 2.0])
    changed = JointState(name=["joint_a", "joint_c"], position=[3.0, 4.0])
    shifted = JointState(name=["joint_a", "joint_c"], position=[5.0, 6.0])
    shifted.header.frame_id = "base"
    for msg in (first, first, changed, first, shifted, changed):
        assert joint_state_from_cdr(serialize_message(msg)) == (tuple(msg.name),
                                                                tuple(msg.position))


def wrench_stamped(rng: np.random.Generator) -> WrenchStamped:
    msg = WrenchStamped()
    msg.header.frame_id = random_name(rng)
    f, tq = msg.wrench.force, msg.wrench.torque
    f.x, f.y, f.z, tq.x, tq.y, tq.z = rng.normal(size=6).tolist()
    return msg


def point_stamped(rng: np.random.Generator) -> PointStamped:
    msg = PointStamped()
    msg.header.frame_id = random_name(rng)
    msg.point.x, msg.point.y, msg.point.z = rng.normal(size=3).tolist()
    return msg


def pose_array(rng: np.random.Generator) -> PoseArray:
    msg = PoseArray()
    msg.header.frame_id = random_name(rng)
    for _ in range(int(rng.integers(0, 7))):
        pose = Pose()
        p, o = pose.position, pose.orientation
        p.x, p.y, p.z, o.x, o.y, o.z, o.w = rng.normal(size=7).tolist()
        msg.poses.append(pose)
    return msg


def test_odometry_twist_stamped_vectors_pose_arrays_and_twists_read_as_rclpy_wrote_them() -> None:
    """The readers the reports use (every frame_id length: every padding case)."""
    rng = np.random.default_rng(RNG_SEED)
    for _ in range(200):
        odom = odometry(rng)
        odom.twist.twist.linear.y, odom.twist.twist.angular.z = rng.normal(size=2).tolist()
        odom.twist.covariance = rng.normal(size=36).tolist()
        p, o = odom.pose.pose.position, odom.pose.pose.orientation
        lin, ang = odom.twist.twist.linear, odom.twist.twist.angular
        assert odometry_from_cdr(serialize_message(odom)) == (
            (p.x, p.y, p.z, o.x, o.y, o.z, o.w), (lin.x, lin.y, lin.z, ang.x, ang.y, ang.z))
        wrench = wrench_stamped(rng)
        f = wrench.wrench.force
        assert stamped_xyz_from_cdr(serialize_message(wrench), "wrench") == (f.x, f.y, f.z)
        point = point_stamped(rng)
        q = point.point
        assert stamped_xyz_from_cdr(serialize_message(point), "point") == (q.x, q.y, q.z)
        poses = pose_array(rng)
        assert pose_array_from_cdr(serialize_message(poses)) == [
            (a.position.x, a.position.y, a.position.z, a.orientation.x, a.orientation.y,
             a.orientation.z, a.orientation.w) for a in poses.poses]
        twist = Twist()
        twist.linear.x, twist.linear.y, twist.linear.z = rng.normal(size=3).tolist()
        twist.angular.x, twist.angular.y, twist.angular.z = rng.normal(size=3).tolist()
        assert twist_from_cdr(serialize_message(twist)) == (
            twist.linear.x, twist.linear.y, twist.linear.z,
            twist.angular.x, twist.angular.y, twist.angular.z)


def test_the_report_readers_leave_big_endian_to_rclpy_and_name_a_truncated_field() -> None:
    rng = np.random.default_rng(RNG_SEED)
    cases = ((odometry_from_cdr, odometry(rng), "odometry"),
             (lambda d: stamped_xyz_from_cdr(d, "wrench"), wrench_stamped(rng), "wrench"),
             (pose_array_from_cdr, pose_array(rng), "pose"),
             (twist_from_cdr, Twist(), "twist"))
    for reader, msg, word in cases:
        data = serialize_message(msg)
        assert reader(big_endian(data)) is None
        assert_truncations_answer_or_name(reader, data, (word, "header", "child_frame_id"))


def test_a_pose_count_beyond_the_bytes_is_refused() -> None:
    msg = PoseArray(poses=[Pose()])
    data = bytearray(serialize_message(msg))
    struct.pack_into("<I", data, 4 + 16, 1000)  # header: stamp 8, frame_id "" 5, pad to 16
    with pytest.raises(CdrError, match="poses: 1000 poses do not fit"):
        pose_array_from_cdr(bytes(data))


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**31 * 10**9 - 1), st.text(alphabet=st.characters(
    blacklist_characters="\x00", blacklist_categories=("Cs",)), max_size=24),
    st.lists(st.lists(st.floats(allow_nan=False, width=64), min_size=7, max_size=7),
             max_size=4))
def test_ground_truth_bytes_read_back_as_the_messages(stamp_ns: int, frame_id: str,
                                                      poses: list[list[float]]) -> None:
    """Any stamp, any frame id (every length: every padding) and any pose count: rclpy reads
    the written bytes back as the message built by hand, and they are as long as rclpy's."""
    stamp = ns_to_stamp(stamp_ns)
    wrench = WrenchStamped()
    wrench.header.stamp, wrench.header.frame_id = stamp, frame_id
    wrench.wrench.force.x, wrench.wrench.force.y, wrench.wrench.force.z = 1.5, -2.0, 3.25
    wrench.wrench.torque.z = 0.5
    point = PointStamped()
    point.header.stamp, point.header.frame_id = stamp, frame_id
    point.point.x, point.point.y, point.point.z = 0.1, 0.2, -0.3
    array = PoseArray()
    array.header.stamp, array.header.frame_id = stamp, frame_id
    for v in poses:
        pose = Pose()
        pose.position.x, pose.position.y, pose.position.z = v[0:3]
        pose.orientation.x, pose.orientation.y, pose.orientation.z, pose.orientation.w = v[3:7]
        array.poses.append(pose)
    written = (
        (wrench, wrench_stamped_to_cdr(stamp_ns, frame_id, (1.5, -2.0, 3.25), (0.0, 0.0, 0.5))),
        (point, point_stamped_to_cdr(stamp_ns, frame_id, (0.1, 0.2, -0.3))),
        (array, pose_array_to_cdr(stamp_ns, frame_id, poses)),
    )
    for msg, data in written:
        assert deserialize_message(data, type(msg)) == msg
        assert len(data) == len(serialize_message(msg))
    assert pose_array_from_cdr(written[2][1]) == [tuple(v) for v in poses]


def test_ground_truth_writers_refuse_what_a_header_cannot_carry() -> None:
    with pytest.raises(ValueError, match="time stamp = -1 ns"):
        wrench_stamped_to_cdr(-1, "link", (0.0, 0.0, 0.0))
    with pytest.raises(ValueError, match="time stamp"):
        point_stamped_to_cdr(2**31 * 10**9, "link", (0.0, 0.0, 0.0))
    with pytest.raises(ValueError, match="frame_id"):
        pose_array_to_cdr(0, "a\x00b", [])
