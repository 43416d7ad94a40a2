"""Fault models (phri_sim.world.sensor_faults): what each fault does to the sensor stream, and
when."""

from __future__ import annotations

import math

import numpy as np
import pytest

from phri_common.taxels import TaxelCloudEncoder, msg_to_taxels
from phri_sim.world.sensor_faults import FaultSpec, SensorFaults

JOINTS = ("a_joint", "left_elbow_joint", "c_joint")


def _faults(kind: str, t: float = 5.0, **kw: object) -> SensorFaults:
    return SensorFaults(FaultSpec(kind, t, **kw), JOINTS)  # type: ignore[arg-type]


def test_no_fault_changes_nothing() -> None:
    faults = SensorFaults(None, JOINTS)
    f = np.array([0.0, 2.0, 1.0])
    assert faults.taxels("p", f, 9.0) is f
    q = np.array([0.1, 0.2, 0.3])
    assert faults.joints(q, 9.0) is q
    assert faults.changes == 0 and faults.first_change is None


def test_skin_blind_reads_zero_from_the_fault_time_on() -> None:
    faults = _faults("skin_blind")
    f = np.array([0.0, 2.0, 1.0])
    assert np.array_equal(faults.taxels("p", f, 4.99), f)
    for t in (5.0, 6.0, 60.0):
        assert not np.any(faults.taxels("p", f, t))
    assert np.array_equal(f, [0.0, 2.0, 1.0])  # the input is never modified
    assert faults.first_change == 5.0 and faults.changes == 3
    assert faults.changed_at(60.0) == {"p"}


def test_skin_stuck_repeats_each_patch_last_frame_before_the_fault() -> None:
    faults = _faults("skin_stuck")
    faults.taxels("a", np.array([1.0, 0.0]), 4.0)
    faults.taxels("a", np.array([3.0, 0.5]), 4.99)
    faults.taxels("b", np.array([0.0, 0.0]), 4.99)
    for t, new in ((5.0, [9.0, 9.0]), (7.0, [0.0, 0.0])):
        assert np.array_equal(faults.taxels("a", np.array(new), t), [3.0, 0.5])
        assert np.array_equal(faults.taxels("b", np.array(new), t), [0.0, 0.0])
    # A patch first seen after the fault freezes at that first frame.
    assert np.array_equal(faults.taxels("c", np.array([2.0]), 6.0), [2.0])
    assert np.array_equal(faults.taxels("c", np.array([5.0]), 6.5), [2.0])


def test_force_spike_hits_the_most_loaded_taxel_of_the_first_touched_frame_once() -> None:
    faults = _faults("force_spike")
    before = np.array([0.0, 4.0, 1.0])
    assert np.array_equal(faults.taxels("a", before, 4.9), before)
    idle = np.zeros(3)
    assert np.array_equal(faults.taxels("idle", idle, 5.0), idle)  # untouched: not this one
    out = faults.taxels("a", before, 5.0)
    assert out[1] == pytest.approx(3.0e38) and out[0] == 0.0 and out[2] == 1.0
    assert np.array_equal(faults.taxels("a", before, 5.01), before)  # one frame only
    assert faults.changes == 1 and faults.changed_at(5.0) == {"a"}


def test_force_spike_survives_the_float32_wire_format() -> None:
    """The spike must reach the estimator as the absurd finite value, not as inf."""
    enc = TaxelCloudEncoder(np.zeros((3, 3)), np.tile([0.0, 0.0, 1.0], (3, 1)), "link")
    out = _faults("force_spike", 0.0).taxels("a", np.array([0.0, 1.0, 0.0]), 0.0)
    decoded = msg_to_taxels(enc.encode(out, 0)).forces
    assert math.isfinite(float(decoded[1])) and decoded[1] > 1e38


def test_joint_jump_changes_one_joint_in_one_message() -> None:
    faults = _faults("joint_jump")
    q = np.array([0.1, 0.2, 0.3])
    assert np.array_equal(faults.joints(q, 4.99), q)
    out = faults.joints(q, 5.0)
    assert out.tolist() == [0.1, 10.0, 0.3]
    assert np.array_equal(faults.joints(q, 5.01), q)
    assert faults.changed_at(5.0) == {"joint_states"} and faults.changes == 1
    assert _faults("joint_jump", value=-7.0).joints(q, 6.0)[1] == -7.0


@pytest.mark.parametrize(("spec", "words"), [
    (lambda: FaultSpec("skin_melted"), ["fault", "skin_melted", "skin_blind"]),
    (lambda: FaultSpec("skin_blind", -1.0), ["fault_time", "-1.0", "[0, inf)"]),
    (lambda: FaultSpec("skin_blind", math.nan), ["fault_time", "nan"]),
    (lambda: SensorFaults(FaultSpec("joint_jump", joint="knee"), JOINTS),
     ["knee", "left_elbow_joint"]),
])
def test_bad_fault_settings_are_refused_by_name(spec: object, words: list[str]) -> None:
    with pytest.raises(ValueError) as err:
        spec()  # type: ignore[operator]
    for word in words:
        assert word in str(err.value)
