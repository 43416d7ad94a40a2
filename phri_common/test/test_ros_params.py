"""Parameter refusals on a real node name the parameter, the value, the type and the range."""

from __future__ import annotations

import pytest
from rclpy.node import Node
from rclpy.parameter import Parameter

from phri_common.params import ParameterValueError, ParamSpec
from phri_common.ros_params import declare_parameters

SPECS = [ParamSpec("gain", 2.0, "a gain", "N/m", 0.0, 10.0),
         ParamSpec("flag", False, "a switch"),
         ParamSpec("weights", [1.0, 2.0], "two weights", "-", 0.0, 5.0, length=2),
         ParamSpec("frame", "odom", "a frame", read_only=True)]


@pytest.mark.ros
def test_run_time_refusals_name_parameter_value_type_and_range(ros_context: object) -> None:
    node = Node("params_test", context=ros_context)  # type: ignore[arg-type]
    try:
        values = declare_parameters(node, SPECS)
        cases = {
            Parameter("gain", value="fast"): ("'gain'", "'fast'", "expected float", "[0, 10]"),
            Parameter("gain", value=11.0): ("'gain'", "11.0", "above", "[0, 10]"),
            Parameter("flag", value=1): ("'flag'", "1", "expected bool", "any"),
            Parameter("weights", value=[1.0]): ("'weights'", "[1.0]", "2 elements", "[0, 5]"),
        }
        for param, words in cases.items():
            result = node.set_parameters([param])[0]
            assert not result.successful
            for word in words:
                assert word in result.reason, (word, result.reason)
        assert node.set_parameters([Parameter("gain", value=3)])[0].successful
        assert values["gain"] == 3.0 and isinstance(values["gain"], float)  # int → double
        assert not node.set_parameters([Parameter("frame", value="map")])[0].successful
    finally:
        node.destroy_node()


@pytest.mark.ros
def test_start_up_override_of_the_wrong_type_is_refused_by_name(ros_context: object) -> None:
    node = Node("params_test2", context=ros_context,  # type: ignore[arg-type]
                parameter_overrides=[Parameter("gain", value="slow")])
    try:
        with pytest.raises(ParameterValueError, match=r"'gain'.*'slow'.*expected float"):
            declare_parameters(node, SPECS)
    finally:
        node.destroy_node()
