"""The controller and a UR's speed scaling: the teach pendant's speed slider scales a
UR's joint speeds but not the base, so the node reads each arm's scaling on ur_robot_driver's topic
(``<arm>/speed_scaling_state_broadcaster/speed_scaling``, Float64 in percent) and, after the step,
commands every axis so that all move at the slowest arm's fraction; below ``min_speed_scaling`` it
commands zero and warns."""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np
import pytest
from diagnostic_msgs.msg import DiagnosticStatus
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.typing import NDArray
from rclpy.parameter import Parameter
from rclpy.serialization import serialize_message
from std_msgs.msg import Float64
from test_node_inputs import RecordingNode, moving

from wholebody_controller.input_checks import InputError
from wholebody_controller.messages import speed_scaling_fraction, speed_scaling_status
from wholebody_controller.node import ARM_COMMAND_SLICES, scale_to_slowest


def executed(command: NDArray[np.float64], scaling: dict[str, float]) -> NDArray[np.float64]:
    """What the robot does with ``command``: each UR multiplies its joints by its own scaling,
    the base runs it as it is."""
    out = np.array(command)
    for arm, part in ARM_COMMAND_SLICES.items():
        out[part] *= scaling.get(arm, 1.0)
    return out


fractions = st.floats(0.0, 1.0)


@settings(max_examples=200, deadline=None)
@given(command=st.lists(st.floats(-1.0, 1.0), min_size=15, max_size=15),
       left=st.one_of(st.none(), fractions), right=st.one_of(st.none(), fractions))
def test_every_axis_moves_at_the_slowest_arms_fraction(command: list[float], left: float | None,
                                                       right: float | None) -> None:
    scaling = {arm: v for arm, v in (("left", left), ("right", right)) if v is not None}
    c = np.array(command)
    out = scale_to_slowest(c, scaling)
    slowest = min(scaling.values(), default=1.0)
    np.testing.assert_allclose(executed(out, scaling), slowest * c, atol=1e-12)
    assert np.all(np.abs(out) <= np.abs(c) + 1e-15)  # never amplified


def test_percent_is_read_as_ur_robot_driver_publishes_it() -> None:
    assert speed_scaling_fraction(30.0) == pytest.approx(0.3)
    assert speed_scaling_fraction(100.0) == 1.0
    for bad in (float("nan"), float("inf"), -1.0, 100.5):
        with pytest.raises(InputError, match="allowed 0–100 %"):
            speed_scaling_fraction(bad)


@pytest.fixture
def node(ros_context: object) -> Iterator[RecordingNode]:
    n = RecordingNode(ros_context)
    yield n
    n.destroy_node()



@pytest.mark.ros
def test_the_node_listens_on_ur_robot_driver_s_topics(node: RecordingNode) -> None:
    topics = {s.topic_name: s.msg_type for s in node.subscriptions}
    for arm in ("left", "right"):
        assert topics[f"/{arm}/speed_scaling_state_broadcaster/speed_scaling"] is Float64


@pytest.mark.ros
def test_scaled_command_is_the_step_s_command_slowed_to_the_slowest_arm(
        node: RecordingNode) -> None:
    assert node.controller is not None
    steps: list[NDArray[np.float64]] = []
    step = node.controller.step

    def recording_step(*args: object, **kwargs: object) -> object:
        result = step(*args, **kwargs)  # type: ignore[arg-type]
        steps.append(np.array(result.command))
        return result

    node.controller.step = recording_step  # type: ignore[method-assign]
    node.cycle()
    np.testing.assert_array_equal(node.commands[-1], steps[-1])  # nothing received: unscaled
    node.on_speed_scaling_bytes("left", serialize_message(Float64(data=60.0)))
    node.take_speed_scaling("right", 100.0)
    command = node.cycle()
    assert moving(command)
    np.testing.assert_allclose(command, scale_to_slowest(steps[-1], {"left": 0.6,
                                                                     "right": 1.0}))
    np.testing.assert_allclose(command[:3], 0.6 * steps[-1][:3])  # the base slowed with them
    np.testing.assert_allclose(command[3:9], steps[-1][3:9])  # the left UR slows itself


@pytest.mark.ros
def test_below_the_minimum_zero_and_a_warning_then_recovery(node: RecordingNode) -> None:
    assert float(node.params["min_speed_scaling"]) == 0.5
    for _ in range(3):
        assert moving(node.cycle())
    zero_cycles = node.zero_cycles
    node.take_speed_scaling("left", 30.0)  # the pendant's slider at 30 %
    assert not moving(node.cycle())
    assert not moving(node.cycle())
    assert node.zero_cycles == zero_cycles + 2
    status = speed_scaling_status("n", dict(node.speed_scaling), 0.5)
    assert status.level == DiagnosticStatus.WARN and "30 %" in status.message
    assert node.controller is not None
    assert all(t.locked_reference is None for t in node.controller.tasks)  # reset once
    result = node.set_parameters([Parameter("min_speed_scaling", value=0.25)])
    assert result[0].successful
    assert moving(node.cycle())  # allowed now: commanded, scaled
    refused = node.set_parameters([Parameter("min_speed_scaling", value=1.5)])
    assert not refused[0].successful and "min_speed_scaling" in refused[0].reason


@pytest.mark.ros
def test_a_bad_scaling_value_is_refused_as_zero_until_the_next_good_one(
        node: RecordingNode) -> None:
    for _ in range(3):
        node.cycle()
    rejected = node.rejected_inputs
    node.take_speed_scaling("right", float("nan"))
    assert node.rejected_inputs == rejected + 1
    assert not moving(node.cycle())
    node.take_speed_scaling("right", 100.0)
    assert moving(node.cycle())
    node.on_speed_scaling_bytes("right", b"\x00\x01\x00")  # truncated: unreadable
    assert node.rejected_inputs == rejected + 2
    assert not moving(node.cycle())
    node.on_speed_scaling_bytes("right", serialize_message(Float64(data=100.0)))
    assert moving(node.cycle())
