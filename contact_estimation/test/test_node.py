"""The contact estimation node in an isolated ROS domain: taxels in → contact states out."""

from __future__ import annotations

import math

import numpy as np
import pytest
from rclpy.executors import SingleThreadedExecutor
from rclpy.parameter import Parameter
from sensor_msgs.msg import PointCloud2
from visualization_msgs.msg import MarkerArray

from contact_estimation.node import ContactEstimationNode
from phri_common.contact import msg_to_contact
from phri_common.params import ParameterValueError
from phri_common.records import ContactState
from phri_common.taxels import TaxelCloudEncoder
from phri_common.testing import spin_until

pytestmark = pytest.mark.ros

WAIT_S = 60.0
"""Longest wait for something that must happen (a stalled machine); never a measured time."""

# Two taxels on opposite sides of a link along x (see test_estimator for the hand computation):
# 3 N at (0.1, 0.05, 0) on the +y side, 1 N at (−0.1, −0.05, 0) on the −y side.
POSITIONS = np.array([[0.1, 0.05, 0.0], [-0.1, -0.05, 0.0], [0.0, 0.0, 0.05]])
NORMALS = np.array([[0.0, 1.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, 1.0]])
FORCES = np.array([3.0, 1.0, 0.0])


@pytest.fixture
def harness(ros_context):
    node = ContactEstimationNode(
        context=ros_context,
        parameter_overrides=[
            Parameter("patches", value=["fore", "upper"]),
            Parameter("patch_links", value=["forearm_link", "upper_arm_link"]),
            Parameter("torque_limit", value=[math.inf, math.inf, 1.2]),
        ],
    )
    peer = node.__class__.__mro__[1]("test_peer", context=ros_context)
    received: dict[str, list[ContactState]] = {"forearm_link": [], "upper_arm_link": []}
    markers: list[MarkerArray] = []
    for link, states in received.items():
        peer.create_subscription(
            PointCloud2, f"contacts/{link}", lambda m, s=states: s.append(msg_to_contact(m)), 10
        )
    peer.create_subscription(MarkerArray, "contacts/markers", markers.append, 10)
    pubs = {
        p: peer.create_publisher(PointCloud2, f"skin/{p}/taxels", 10) for p in ("fore", "upper")
    }
    executor = SingleThreadedExecutor(context=ros_context)
    executor.add_node(node)
    executor.add_node(peer)
    # Wait for discovery in both directions before publishing.
    assert spin_until(
        executor,
        lambda: all(p.get_subscription_count() > 0 for p in pubs.values())
        and peer.count_publishers("contacts/forearm_link") > 0,
        timeout_s=WAIT_S,
    )
    yield node, pubs, received, markers, executor
    executor.shutdown()
    peer.destroy_node()
    node.destroy_node()


def test_taxels_in_contact_state_out(harness) -> None:
    _, pubs, received, markers, executor = harness
    encoder = TaxelCloudEncoder(POSITIONS, NORMALS, "forearm_link")
    pubs["fore"].publish(encoder.encode(FORCES, 123_000_000))
    assert spin_until(executor, lambda: len(received["forearm_link"]) >= 1, timeout_s=WAIT_S)
    state = received["forearm_link"][-1]
    assert state.in_contact and state.taxel_count == 2 and state.stamp_ns == 123_000_000
    np.testing.assert_allclose(state.center, [0.0, 0.0, 0.0], atol=1e-7)
    np.testing.assert_allclose(state.force, [0.0, -2.0, 0.0], atol=1e-6)
    np.testing.assert_allclose(state.torque, [0.0, 0.0, -0.4], atol=1e-6)
    np.testing.assert_allclose(state.region_min, [-0.1, -0.05, 0.0], atol=1e-7)
    np.testing.assert_allclose(state.region_max, [0.1, 0.05, 0.0], atol=1e-7)
    assert spin_until(executor, lambda: len(markers) >= 1, timeout_s=WAIT_S)
    assert {m.ns for m in markers[-1].markers} == {"forearm_link"}
    assert not received["upper_arm_link"]  # nothing published for a link without frames


def test_bad_frames_are_refused_and_the_other_patch_keeps_working(harness) -> None:
    node, pubs, received, _, executor = harness
    nan_forces = FORCES.copy()
    nan_forces[0] = np.nan
    encoder = TaxelCloudEncoder(POSITIONS, NORMALS, "forearm_link")
    pubs["fore"].publish(encoder.encode(nan_forces, 1))
    wrong_frame = TaxelCloudEncoder(POSITIONS, NORMALS, "base_link").encode(FORCES, 2)
    pubs["fore"].publish(wrong_frame)
    truncated = TaxelCloudEncoder(POSITIONS, NORMALS, "forearm_link").encode(FORCES, 3)
    truncated.data = bytes(truncated.data)[:-5]
    pubs["fore"].publish(truncated)
    assert spin_until(executor, lambda: node.refused_frames["fore"] == 3, timeout_s=WAIT_S)
    pubs["upper"].publish(
        TaxelCloudEncoder(POSITIONS, NORMALS, "upper_arm_link").encode(FORCES * 2.0, 4)
    )
    assert spin_until(executor, lambda: len(received["upper_arm_link"]) >= 1, timeout_s=WAIT_S)
    np.testing.assert_allclose(received["upper_arm_link"][-1].force, [0.0, -4.0, 0.0], atol=1e-6)
    assert not received["forearm_link"]  # refused frames never produced a state
    assert node.refused_frames["upper"] == 0


def test_torque_limit_parameter_applies_at_run_time_and_bad_values_are_refused(harness) -> None:
    node, pubs, received, _, executor = harness
    result = node.set_parameters([Parameter("torque_limit", value=[1.0, 1.0, -0.5])])[0]
    assert not result.successful
    assert "torque_limit" in result.reason and "[0, inf]" in result.reason
    assert node.set_parameters([Parameter("torque_limit", value=[1.0, 1.0, 0.25])])[0].successful
    scalar = node.set_parameters([Parameter("force_threshold", value=math.nan)])[0]
    assert not scalar.successful and "force_threshold" in scalar.reason
    assert node.get_parameter("force_threshold").value == 0.05
    pubs["fore"].publish(TaxelCloudEncoder(POSITIONS, NORMALS, "forearm_link").encode(FORCES, 5))
    assert spin_until(executor, lambda: len(received["forearm_link"]) >= 1, timeout_s=WAIT_S)
    np.testing.assert_allclose(received["forearm_link"][-1].torque, [0.0, 0.0, -0.25], atol=1e-6)


def test_bad_start_up_parameter_is_refused_with_name_and_range(ros_context) -> None:
    with pytest.raises(ParameterValueError, match=r"force_threshold.*\[0, 1000\]"):
        ContactEstimationNode(
            context=ros_context, parameter_overrides=[Parameter("force_threshold", value=-1.0)]
        )
    with pytest.raises(ValueError, match="same length"):
        ContactEstimationNode(
            context=ros_context,
            parameter_overrides=[Parameter("patches", value=["a", "b"]),
                                 Parameter("patch_links", value=["l"])],
        )


def test_nan_geometry_is_refused_on_every_frame_through_the_node(harness) -> None:
    node, pubs, received, _, executor = harness
    assert node.get_parameter("geometry_check_interval").value == 50
    pubs["fore"].publish(TaxelCloudEncoder(POSITIONS, NORMALS, "forearm_link").encode(FORCES, 1))
    assert spin_until(executor, lambda: len(received["forearm_link"]) == 1, timeout_s=WAIT_S)
    for k in range(50):  # every frame of a whole geometry-check interval carries one NaN
        positions, normals = POSITIONS.copy(), NORMALS.copy()
        (positions if k % 2 else normals)[k % 3, k % 3] = np.nan
        pubs["fore"].publish(
            TaxelCloudEncoder(positions, normals, "forearm_link").encode(FORCES, 2 + k)
        )
        assert spin_until(
            executor, lambda k=k: node.refused_frames["fore"] == k + 1, timeout_s=WAIT_S
        )
    # A good frame after them: its state is the next one (states arrive in publication order),
    # so not one state came from the 50 bad frames.
    pubs["fore"].publish(TaxelCloudEncoder(POSITIONS, NORMALS, "forearm_link").encode(FORCES, 99))
    assert spin_until(executor, lambda: len(received["forearm_link"]) >= 2, timeout_s=WAIT_S)
    assert [s.stamp_ns for s in received["forearm_link"]] == [1, 99]


def test_max_taxel_force_and_diagnostics_period_take_effect_at_run_time(harness) -> None:
    node, pubs, received, _, executor = harness
    encoder = TaxelCloudEncoder(POSITIONS, NORMALS, "forearm_link")
    pubs["fore"].publish(encoder.encode(FORCES * 100.0, 1))  # 300 N on one taxel: accepted
    assert spin_until(executor, lambda: len(received["forearm_link"]) == 1, timeout_s=WAIT_S)
    refused = node.set_parameters([Parameter("max_taxel_force", value=0.1)])[0]
    assert not refused.successful
    assert "max_taxel_force" in refused.reason and "0.1" in refused.reason
    assert "1000000" in refused.reason or "1e+06" in refused.reason  # the allowed range
    assert node.set_parameters([Parameter("max_taxel_force", value=200.0)])[0].successful
    pubs["fore"].publish(encoder.encode(FORCES * 100.0, 2))
    assert spin_until(executor, lambda: node.refused_frames["fore"] == 1, timeout_s=WAIT_S)
    assert len(received["forearm_link"]) == 1
    assert node.set_parameters([Parameter("diagnostics_period", value=0.25)])[0].successful
    assert node._diag_timer.timer_period_ns == 250_000_000


def test_markers_are_throttled_to_marker_rate_hz(harness) -> None:
    """100 frames at 500 Hz (0.2 s of stamps) give 100 contact states but, at 30 Hz, only the
    markers of the first frame and one per 1/30 s after it; a released contact is drawn
    (deleted) at once."""
    _, pubs, received, markers, executor = harness
    encoder = TaxelCloudEncoder(POSITIONS, NORMALS, "forearm_link")
    for i in range(100):
        pubs["fore"].publish(encoder.encode(FORCES, 1_000_000_000 + i * 2_000_000))
        assert spin_until(executor, lambda n=i + 1: len(received["forearm_link"]) >= n, WAIT_S)
    # The release is drawn at once, after the throttled markers (one publisher: in order).
    pubs["fore"].publish(encoder.encode(np.zeros(3), 1_000_000_000 + 100 * 2_000_000))

    def deleted() -> bool:
        return bool(markers) and all(m.action == m.DELETE for m in markers[-1].markers)

    assert spin_until(executor, deleted, timeout_s=WAIT_S)
    drawn = len(markers) - 1
    assert 6 <= drawn <= 8  # 0.198 s / (1/30 s) = 5.94 periods → 6 (+ the first)


def test_a_frame_of_another_geometry_is_refused_until_reset_geometry(harness) -> None:
    """A patch's geometry is learnt from its first frame; a frame of another size is refused,
    counted and reported with both sizes, the next good frame is used; ~/reset_geometry (a
    real service call) announces a new geometry."""
    from std_srvs.srv import Trigger

    node, pubs, received, _, executor = harness
    good = TaxelCloudEncoder(POSITIONS, NORMALS, "forearm_link")
    four = np.vstack([POSITIONS, [[0.0, 0.0, -0.05]]]), np.vstack([NORMALS, [[0.0, 0.0, -1.0]]])
    bigger = TaxelCloudEncoder(*four, "forearm_link")
    pubs["fore"].publish(good.encode(FORCES, 1))
    assert spin_until(executor, lambda: len(received["forearm_link"]) == 1, timeout_s=WAIT_S)
    pubs["fore"].publish(bigger.encode(np.append(FORCES, 5.0), 2))
    assert spin_until(executor, lambda: node.refused_frames["fore"] == 1, timeout_s=WAIT_S)
    pubs["fore"].publish(good.encode(FORCES, 3))
    assert spin_until(executor, lambda: len(received["forearm_link"]) == 2, timeout_s=WAIT_S)
    assert received["forearm_link"][-1].taxel_count == 2  # the learnt geometry, 3 taxels
    status = node.patch_status("fore")
    values = {kv.key: kv.value for kv in status.values}
    assert "1 of another geometry (4 taxels, the patch has 3)" in status.message
    assert (values["geometry_mismatches"], values["mismatch_taxels"], values["taxels"]) == (
        "1", "4", "3")
    caller = node.__class__.__mro__[1]("reset_caller", context=node.context)
    executor.add_node(caller)
    client = caller.create_client(Trigger, "/contact_estimation/reset_geometry")
    assert spin_until(executor, client.service_is_ready, timeout_s=WAIT_S)
    future = client.call_async(Trigger.Request())
    assert spin_until(executor, future.done, timeout_s=WAIT_S)
    assert future.result().success
    executor.remove_node(caller)
    caller.destroy_node()
    pubs["fore"].publish(bigger.encode(np.append(FORCES, 5.0), 4))
    assert spin_until(executor, lambda: len(received["forearm_link"]) == 3, timeout_s=WAIT_S)
    assert received["forearm_link"][-1].taxel_count == 3  # now 4 taxels, 3 in contact
    assert node.refused_frames["fore"] == 1
