"""The in-process bringup: every scenario starts and stops cleanly, the recording holds every
documented topic with its type, the panels come from it, a push moves the robot, NaN input
leaves every node running. (The launch_testing twins are in test_launch_sim.py.)"""

from __future__ import annotations

import threading
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from phri_bringup.cli.session import StopFlag, run_session
from phri_bringup.graph.nodes import RECORDED_EXTRA_TOPICS, SIM_TOPICS
from phri_bringup.observer.node import RecordingSink
from phri_sim.ros.run_options import RunOptions

pytestmark = pytest.mark.ros


@pytest.mark.parametrize("scenario", ["centring", "sliding", "wholebody", "waltz"])
def test_every_scenario_starts_and_stops_with_zero_velocity(ros_context: Any,
                                                            scenario: str) -> None:
    threads_before = threading.active_count()
    result = run_session(scenario, RunOptions(duration=0.3), context=ros_context)
    assert result.zero_at_exit
    assert not result.interrupted
    assert result.metrics["duration"] == pytest.approx(0.3)
    assert result.metrics["commands_refused"] == 0
    # Commands flowed every control period, then the final zero on top.
    assert result.message_counts["/cmd_vel"] >= 30
    assert threading.active_count() <= threads_before + 1


def test_stop_request_ends_early_with_zero_velocity(ros_context: Any) -> None:
    stop = StopFlag()
    seen: list[float] = []

    def progress(t: float, total: float) -> None:
        seen.append(t)
        stop.set()

    result = run_session("centring", RunOptions(duration=30.0), context=ros_context, stop=stop,
                         progress=progress)
    assert result.interrupted and result.zero_at_exit
    assert len(seen) == 1 and seen[0] == pytest.approx(1.0)


@pytest.fixture(scope="module")
def recorded_run(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Any]:
    """A 2.5 s centring run (the press starts at 1 s), recorded with every taxel frame."""
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.node import Node
    from rclpy.qos import DurabilityPolicy, QoSProfile
    from std_msgs.msg import String

    from phri_common.testing import ros_context_scope

    directory = tmp_path_factory.mktemp("run") / "recording"
    with ros_context_scope() as context:
        # rviz's way of getting the URDF: a transient-local subscription to /robot_description.
        viewer = Node("urdf_viewer", context=context)
        urdfs: list[str] = []
        viewer.create_subscription(String, "/robot_description", lambda m: urdfs.append(m.data),
                                   QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL))

        executor = SingleThreadedExecutor(context=context)
        executor.add_node(viewer)

        deadline: list[float] = []

        def look(t: float, duration: float) -> None:  # once per simulated second
            """Spin until the URDF came (the sim waits meanwhile); 60 s in all bound a stalled
            machine only."""
            del t, duration
            deadline[:] = deadline or [time.monotonic() + 60.0]
            while not urdfs and time.monotonic() < deadline[0]:
                executor.spin_once(timeout_sec=0.05)

        result = run_session("centring", RunOptions(duration=2.5), context=context, progress=look,
                             sinks=[RecordingSink(str(directory), skin_rate_hz=0.0)])
    result.message_counts["urdf"] = urdfs  # type: ignore[assignment]
    return directory, result


def test_phri_sim_publishes_the_robot_description(recorded_run: Any) -> None:
    """In ``phri sim`` (no robot_state_publisher) the URDF is on /robot_description, latched."""
    from phri_description.urdf_writer import urdf_string

    _, result = recorded_run
    urdfs = result.message_counts["urdf"]
    assert urdfs and urdfs[0] == urdf_string()


def test_recording_holds_every_documented_topic_with_its_type(recorded_run: Any) -> None:
    from rosbags.highlevel import AnyReader

    directory, result = recorded_run
    with AnyReader([directory]) as reader:
        topics = {c.topic: c.msgtype for c in reader.connections}
        for spec in (*SIM_TOPICS, *RECORDED_EXTRA_TOPICS):
            assert topics.get(spec.name) == spec.type, spec.name
        counts = {c.topic: c.msgcount for c in reader.connections}
        # 100 Hz sim topics over 2.5 s; the runner may thin out the frames of an untouched
        # skin patch (and so its contact states), so those are only required at 10 Hz.
        for name in ("/joint_states", "/odom", "/cmd_vel"):
            assert counts[name] >= 240, name
        for patch in ("left_upper_arm", "left_forearm", "right_forearm"):
            assert counts[f"/skin/{patch}/taxels"] >= 24, patch
            assert counts[f"/contacts/{patch}_link"] >= 24, patch
        # Every message deserialises with rosbags; the last commands are the final zeros.
        last: dict[str, Any] = {}
        for conn, _, raw in reader.messages():
            msg = reader.deserialize(raw, conn.msgtype)
            if conn.topic in ("/cmd_vel", "/left/forward_velocity_controller/commands",
                              "/right/forward_velocity_controller/commands"):
                last[conn.topic] = msg
    twist = last["/cmd_vel"]
    assert [twist.linear.x, twist.linear.y, twist.angular.z] == [0.0, 0.0, 0.0]
    for arm in ("left", "right"):
        data = np.asarray(last[f"/{arm}/forward_velocity_controller/commands"].data)
        assert data.shape == (6,) and np.all(data == 0.0)
    assert result.zero_at_exit


def test_recording_decodes_with_mcap_ros2_too(recorded_run: Any) -> None:
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    directory, _ = recorded_run
    with next(directory.glob("*.mcap")).open("rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        seen: dict[str, set[str]] = {}
        for _, channel, _, msg in reader.iter_decoded_messages(topics=["/tf", "/tf_static"]):
            assert channel.message_encoding == "cdr"
            seen.setdefault(channel.topic, set()).update(t.child_frame_id
                                                         for t in msg.transforms)
    # Moving joints on /tf, fixed ones (a skin link on its joint's helper frame) on /tf_static.
    assert {"base_link", "left_forearm_link_motion", "right_wrist_3_link_motion"} <= seen["/tf"]
    assert {"left_forearm_link", "right_wrist_3_link", "torso_link"} <= seen["/tf_static"]
    assert not seen["/tf"] & seen["/tf_static"]


def test_push_moves_the_robot_and_plots_show_it(recorded_run: Any, tmp_path: Path) -> None:
    """The right forearm is pressed from 1 s on: the estimated force rises to the order of the
    15 N press, the robot yields (arm joints move, within the 0.15 rad/s bound) and ψ rises."""
    from phri_bringup.reports.plots import make_plots, read_run

    directory, _ = recorded_run
    data = read_run(directory)
    link = "right_forearm_link"
    force = np.linalg.norm(data.force[link].v, axis=1)
    assert force[data.force[link].t < 0.9].max() < 0.5
    assert 5.0 < force.max() < 30.0
    qd = np.abs(data.joint_velocity.v)
    assert qd[data.joint_velocity.t < 0.9].max() < 1e-3
    assert 1e-3 < qd[data.joint_velocity.t > 1.5].max() <= 0.15 + 0.02
    assert data.psi[link].v.max() > 1e-3
    files, numbers = make_plots(directory, tmp_path / "plots", scenario="centring")
    names = {f.name for f in files}
    assert {"contact_force.png", "contact_torque.png", "contact_centre.png", "priority_psi.png",
            "arm_joint_velocities.png", "base_velocity.png", "fig6_contact_centring.png"} == names
    for f in files:
        assert f.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and f.stat().st_size > 10_000
    assert numbers["links"][link]["peak_force"] == pytest.approx(force.max())
    assert (tmp_path / "plots" / "plots.json").is_file()


def test_nan_input_leaves_every_node_running(ros_context: Any) -> None:
    """NaN taxel frames and a NaN velocity command mid-run are refused; the run goes on and
    ends with zero velocity (cartesian_controllers' test_nans, in process). The frames come over
    the taxel topic, to which the estimator subscribes with the sensor data over topics."""
    from geometry_msgs.msg import Twist
    from rclpy.node import Node
    from sensor_msgs.msg import PointCloud2

    from phri_common.taxels import TaxelCloudEncoder

    runs: list[Any] = []
    injector = Node("nan_injector", context=ros_context)
    skin_pub = injector.create_publisher(PointCloud2, "skin/right_forearm/taxels", 10)
    cmd_pub = injector.create_publisher(Twist, "/cmd_vel", 10)

    def inspect(run: Any) -> None:
        runs.append(run)

    def inject(t: float, total: float) -> None:
        layout = runs[0].bridge.sim.patches["right_forearm"].layout
        enc = TaxelCloudEncoder(layout.positions, layout.normals, layout.link)
        forces = np.full(layout.positions.shape[0], np.nan)
        skin_pub.publish(enc.encode(forces, runs[0].bridge.stamp_ns))
        cmd_pub.publish(Twist())
        bad = Twist()
        bad.linear.x = float("nan")
        cmd_pub.publish(bad)

    try:
        result = run_session("centring", RunOptions(duration=2.0, sensor_transport="topics"),
                             context=ros_context, inspect=inspect, progress=inject)
    finally:
        injector.destroy_node()
    run = runs[0]
    assert sum(run.estimation.refused_frames.values()) >= 1
    assert result.metrics["commands_refused"] >= 1
    assert result.metrics["duration"] == pytest.approx(2.0)
    assert result.zero_at_exit


def test_the_session_scenario_is_the_files_values_and_leaves_the_catalogue(
        tmp_path: Path) -> None:
    """The parameter file's controller section becomes a scenario value (what the runner gets);
    the catalogue's scenario is not changed, and a file for another scenario is refused."""
    from phri_bringup.cli.session import session_scenario
    from phri_bringup.graph.nodes import config_file
    from phri_sim.scenarios.catalogue import SCENARIOS

    text = config_file("waltz").read_text(encoding="utf-8")
    assert "    k_eta: 300.0\n" in text
    edited = tmp_path / "waltz.yaml"
    edited.write_text(text.replace("    k_eta: 300.0\n", "    k_eta: 900.0\n"), encoding="utf-8")
    values = session_scenario("waltz", edited)
    assert values.controller_parameters["k_eta"] == 900.0
    assert values.name == "waltz"
    assert SCENARIOS["waltz"].controller_parameters["k_eta"] == 300.0
    with pytest.raises(ValueError, match="parameter file is for scenario 'waltz'"):
        session_scenario("centring", edited)
