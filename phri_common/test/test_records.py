"""The core value types: immutable, comparable, and free of ROS message imports."""

from __future__ import annotations

import pickle
import subprocess
import sys

import numpy as np
import pytest

from phri_common.records import ContactState, TaxelArray

ROS_MODULES = ("rclpy", "sensor_msgs", "std_msgs", "geometry_msgs", "nav_msgs",
               "visualization_msgs", "diagnostic_msgs", "builtin_interfaces", "rosidl_runtime_py")


def touching(**changes: object) -> ContactState:
    fields: dict[str, object] = {
        "link": "left_forearm_link", "stamp_ns": 7, "in_contact": True,
        "center": [0.1, 0.2, 0.3], "force": [1.0, 2.0, 3.0], "torque": [0.0, 0.1, 0.0],
        "region_min": [0.0, 0.1, 0.2], "region_max": [0.2, 0.3, 0.4], "taxel_count": 5,
    }
    fields.update(changes)
    return ContactState(**fields)  # type: ignore[arg-type]


def test_contact_state_equality_compares_every_field() -> None:
    assert touching() == touching()
    assert hash(touching()) == hash(touching())
    for change in ({"link": "x"}, {"stamp_ns": 8}, {"in_contact": False}, {"taxel_count": 6},
                   {"center": [0.1, 0.2, 0.31]}, {"force": [1.0, 2.0, 3.5]},
                   {"torque": [0.0, 0.1, 0.2]}, {"region_min": [0.0, 0.1, 0.25]},
                   {"region_max": [0.2, 0.3, 0.5]}):
        assert touching(**change) != touching(), change


def test_contact_state_is_immutable_and_keeps_no_reference_to_a_writable_input() -> None:
    center = np.array([0.1, 0.2, 0.3])
    state = touching(center=center)
    center[0] = 9.0
    assert state.center[0] == 0.1
    with pytest.raises(ValueError, match="read-only"):
        state.force[0] = 5.0
    with pytest.raises(AttributeError):
        state.link = "other"  # type: ignore[misc]


def test_read_only_views_are_taken_without_a_copy() -> None:
    table = np.arange(15.0)
    table.flags.writeable = False
    state = touching(center=table[0:3])
    assert np.shares_memory(state.center, table)
    writable = np.arange(15.0)
    view = writable[0:3].view()
    view.flags.writeable = False  # read-only view of writable memory: must be copied
    assert not np.shares_memory(touching(center=view).center, writable)


def test_rows_and_no_contact_give_the_same_states_as_the_constructor() -> None:
    """from_row (checked), from_frozen_row (the estimator's unchecked path) and no_contact are
    the constructor's states: equal, immutable, and the row's slices in field order."""
    row = np.array([0.1, 0.2, 0.3, 1.0, 2.0, 3.0, 0.0, 0.1, 0.0, 0.0, 0.1, 0.2, 0.2, 0.3, 0.4])
    row.flags.writeable = False
    for state in (ContactState.from_row("left_forearm_link", 7, True, row, 5),
                  ContactState.from_frozen_row("left_forearm_link", 7, True, row, 5)):
        assert state == touching()
        assert np.shares_memory(state.region_max, row)
        with pytest.raises(ValueError, match="read-only"):
            state.torque[0] = 1.0
    idle = ContactState.no_contact("l", 3)
    assert idle == ContactState("l", 3)
    assert not idle.in_contact and idle.taxel_count == 0
    with pytest.raises(ValueError, match="read-only"):
        idle.center[0] = 1.0


def test_wrong_shapes_name_the_field() -> None:
    with pytest.raises(ValueError, match=r"contact state torque must have shape \(3,\)"):
        touching(torque=[1.0, 2.0])
    with pytest.raises(ValueError, match=r"taxel normals must have shape \(2, 3\)"):
        TaxelArray(np.zeros((2, 3)), np.zeros((3, 3)), np.zeros(2), None, "l", 0)


def test_taxel_array_is_immutable_with_equality() -> None:
    positions = np.zeros((3, 3), dtype=np.float32)
    a = TaxelArray(positions, np.ones((3, 3)), np.arange(3.0), None, "l", 1)
    positions[0, 0] = 1.0
    assert a.positions[0, 0] == 0.0
    assert a.positions.dtype == np.float32  # float32 messages stay float32 (no widening copy)
    with pytest.raises(ValueError, match="read-only"):
        a.forces[0] = 1.0
    assert a == TaxelArray(np.zeros((3, 3)), np.ones((3, 3)), np.arange(3.0), None, "l", 1)
    assert a != TaxelArray(np.zeros((3, 3)), np.ones((3, 3)), np.arange(3.0), np.ones(3), "l", 1)
    assert a != TaxelArray(np.zeros((3, 3)), np.ones((3, 3)), np.arange(3.0) + 1, None, "l", 1)
    assert a != TaxelArray(np.zeros((3, 3)), np.ones((3, 3)), np.arange(3.0), None, "l", 2)


@pytest.mark.parametrize("module", ["wholebody_controller.controller",
                                    "contact_estimation.estimator", "phri_common.records"])
def test_core_imports_no_ros_message_package(module: str) -> None:
    code = (f"import sys, {module}; "
            f"print(','.join(m for m in sys.modules if m.split('.')[0] in {ROS_MODULES!r}))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True, timeout=120)
    assert out.stdout.strip() == "", f"{module} imports ROS modules: {out.stdout}"


def test_a_contact_state_pickles_to_the_same_immutable_state() -> None:
    """Worker processes (the parallel video render) receive contact states by pickle."""
    state = ContactState("left_forearm_link", 12, True, center=(0.1, 0.2, 0.3),
                         force=(1.0, 2.0, 3.0), torque=(0.0, 0.1, 0.0), taxel_count=7)
    copy = pickle.loads(pickle.dumps(state))
    for name in ContactState.__slots__:
        assert np.array_equal(getattr(copy, name), getattr(state, name)), name
    with pytest.raises(AttributeError):
        copy.force = (0.0, 0.0, 0.0)  # type: ignore[misc]
