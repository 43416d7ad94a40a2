"""The step compiled (``kernel="numba"``) against the same functions interpreted
(``kernel="python"``, :mod:`wholebody_controller.kernels`) on the real robot's kinematics and on
the generic path: numba's semantics (integer and float rules, tuples, slices) must not change
what the Python code says. Randomized configurations and contact sequences cover every phase,
every contact-safety state, the desired region's window and hysteresis, the lead moment and
carried reference, user references and regions, priority locks and manual desired forces. Every
task output, the QP data within 1e-9, the command within 1e-7 (daqp's active-set tolerances, as
in ``test_equivalence.py``), and the task state rows after the run.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from wbc_fake_kinematics import FakeKinematics
from wbc_scenarios import Q0, configs, touch_sequence
from wbc_tolerances import QP_TOL, close

from phri_common.records import ContactState
from phri_common.testing import examples
from wholebody_controller.config import (
    SKIN_LINKS,
    WALTZ,
    ControllerConfig,
    LinkTaskConfig,
)
from wholebody_controller.contact_safety import Safety, SafetyConfig
from wholebody_controller.contact_task import Phase
from wholebody_controller.controller import StepResult, WholeBodyController
from wholebody_controller.kinematics import RobotKinematics
from wholebody_controller.parameters import PARAMS, config_from_values
from wholebody_controller.qp import QPError


def assert_same(fast: StepResult, ref: StepResult, k: int) -> None:
    close(fast.command, ref.command, f"command, step {k}", QP_TOL)
    for name in ("hessian", "gradient", "lower", "upper"):
        close(getattr(fast.problem, name), getattr(ref.problem, name), f"{name}, step {k}")
    for a, b in zip(fast.tasks, ref.tasks, strict=True):
        what = f"{b.link}, step {k}"
        assert (a.link, a.phase, a.in_contact, a.safety) == (
            b.link, b.phase, b.in_contact, b.safety), what
        assert type(a.phase) is Phase and type(a.safety) is Safety
        close([a.psi, a.psi_raw], [b.psi, b.psi_raw], f"ψ {what}")
        close(a.values, b.values, f"values {what}")
    close(np.concatenate(fast.tracking_errors), np.concatenate(ref.tracking_errors),
          f"tracking errors, step {k}", QP_TOL)


def assert_same_task_state(fast: WholeBodyController, ref: WholeBodyController) -> None:
    """The two controllers' task state rows agree (NaN where both have it)."""
    close(fast.state, ref.state, "task state rows")


def run_both(config: ControllerConfig, sequence: list[dict[str, ContactState]],
             ) -> tuple[WholeBodyController, WholeBodyController, list[StepResult]]:
    fast = WholeBodyController(RobotKinematics(), replace(config, kernel="numba"))
    ref = WholeBodyController(RobotKinematics(), replace(config, kernel="python"))
    assert (fast.kernel.name, ref.kernel.name) == ("numba", "python")
    q = Q0.copy()
    results = []
    for k, contacts in enumerate(sequence):
        a, b = fast.step(q, contacts), ref.step(q, contacts)
        assert_same(a, b, k)
        results.append(b)
        q = q + config.dt * b.qdot  # the same motion on both sides
    return fast, ref, results


@settings(max_examples=examples(0.25), suppress_health_check=[HealthCheck.too_slow])
@given(configs(), st.integers(0, 2**31 - 1), st.sampled_from([5.0, 40.0]))
def test_compiled_step_equals_python_step(config: ControllerConfig, seed: int,
                                          force_scale: float) -> None:
    rng = np.random.default_rng(seed)
    sequence = touch_sequence(rng, 150, force_scale, config.dt)
    fast, ref, _ = run_both(config, sequence)
    assert_same_task_state(fast, ref)


def test_every_phase_and_safety_state_is_compared() -> None:
    """One fixed case that visits all phases and safety states (so the comparison covers
    them): low force limits, a desired force that loses its contact, the waltz's lead."""
    links = tuple(LinkTaskConfig(link, WALTZ, desired_force=(0.0, -10.0, 0.0),
                                 force_limit=30.0, transient_force_limit=40.0)
                  for link in SKIN_LINKS)
    config = ControllerConfig(links=links, lead_moment=True, region_window=0.05,
                              region_hysteresis=0.0075, rate_hz=500.0,
                              safety=SafetyConfig(regain_time=0.1))
    sequence = touch_sequence(np.random.default_rng(7), 600, 25.0, config.dt)
    _, _, results = run_both(config, sequence)
    phases = {task.phase for res in results for task in res.tasks}
    safeties = {task.safety for res in results for task in res.tasks}
    assert phases == set(Phase), phases
    assert safeties == set(Safety), safeties


def test_state_read_and_changed_through_the_tasks_carries_on() -> None:
    """Reading ``tasks`` changes nothing; a reset through a task handle and a reconfigure that
    keeps the tasks act on the rows both kernels step."""
    config = ControllerConfig(lead_moment=True, region_hysteresis=0.0075)
    sequence = touch_sequence(np.random.default_rng(11), 240, 10.0, config.dt)
    fast = WholeBodyController(RobotKinematics(), config)
    ref = WholeBodyController(RobotKinematics(), replace(config, kernel="python"))
    q = Q0.copy()
    for k, contacts in enumerate(sequence):
        if k == 60:
            before = fast.state.copy()
            assert [t.link for t in fast.tasks] == list(SKIN_LINKS)
            np.testing.assert_array_equal(fast.state, before)
            assert_same_task_state(fast, ref)
        if k == 120:
            fast.tasks[1].reset()
            ref.tasks[1].reset()
            assert not np.any(fast.state[1]) and np.any(fast.state[0] != 0.0)
        if k == 180:
            fast.configure(replace(config, epsilon=0.2))
            ref.configure(replace(config, epsilon=0.2, kernel="python"))
        a, b = fast.step(q, contacts), ref.step(q, contacts)
        assert_same(a, b, k)
        q = q + config.dt * b.qdot
    fast.reset()
    ref.reset()
    assert_same(fast.step(q, sequence[0]), ref.step(q, sequence[0]), -1)


def test_switching_the_kernel_keeps_the_task_state() -> None:
    config = ControllerConfig()
    sequence = touch_sequence(np.random.default_rng(5), 200, 10.0, config.dt)
    switching = WholeBodyController(RobotKinematics(), config)
    ref = WholeBodyController(RobotKinematics(), replace(config, kernel="python"))
    q = Q0.copy()
    for k, contacts in enumerate(sequence):
        if k % 50 == 25:
            kernel = "python" if switching.config.kernel == "numba" else "numba"
            switching.configure(replace(config, kernel=kernel))
        a, b = switching.step(q, contacts), ref.step(q, contacts)
        assert_same(a, b, k)
        q = q + config.dt * b.qdot


@pytest.mark.parametrize("kernel", ["numba", "python"])
def test_other_kinematics_run_the_generic_path_alike(kernel: str) -> None:
    """A kinematics the one-call step cannot drive (the independent D-H robot) steps the same
    task rows, with its own Jacobians, under either kernel."""
    config = ControllerConfig(lead_moment=True)
    sequence = touch_sequence(np.random.default_rng(3), 120, 20.0, config.dt)
    generic = WholeBodyController(FakeKinematics(), replace(config, kernel=kernel))
    python = WholeBodyController(FakeKinematics(), replace(config, kernel="python"))
    q = Q0.copy()
    for k, contacts in enumerate(sequence):
        a, b = generic.step(q, contacts), python.step(q, contacts)
        assert_same(a, b, k)
        q = q + config.dt * b.qdot
    assert_same_task_state(generic, python)


def test_unknown_kernel_is_refused_naming_the_parameter() -> None:
    with pytest.raises(ValueError, match="parameter 'kernel' refused value 'fortran'"):
        ControllerConfig(kernel="fortran")
    values = {spec.name: spec.default for spec in PARAMS}
    values["kernel"] = "fortran"
    with pytest.raises(ValueError, match="parameter 'kernel' refused value 'fortran'"):
        config_from_values(values, [], RobotKinematics().joint_names[3:])


@pytest.mark.parametrize("kernel", ["numba", "python"])
def test_non_finite_qp_data_raises_on_both_kernels(kernel: str) -> None:
    """A contact centre so far out that H overflows is refused alike (QPError, no command)."""
    ctl = WholeBodyController(RobotKinematics(), ControllerConfig(kernel=kernel))
    link = SKIN_LINKS[0]
    far = np.array([1e200, 0.0, 0.0])
    state = ContactState(link, 0, True, far, np.array([1.0, 1.0, 0.0]), np.zeros(3), far - 0.01,
                         far + 0.01, 5)
    with np.errstate(over="ignore", invalid="ignore"), \
            pytest.raises(QPError, match="not finite"):
        ctl.step(Q0, {link: state})


def test_every_entry_point_shows_numba_where_its_cache_lies() -> None:
    """The stale-cache guard finds the cache of each compiled entry point with the installed
    numba: where it could not (numba 0.68 keeps the index path on the cache *file*), a changed
    step ran the machine code of the old source."""
    from numba import njit

    from wholebody_controller import kernels, task_step, whole_step

    for function in (task_step.step_links, whole_step.qp_of_step, whole_step.step_robot):
        stem = kernels._cache_stem(njit(cache=True)(function))
        assert stem is not None, function.__name__
        assert stem.name.startswith(f"{function.__module__.rsplit('.', 1)[1]}."
                                    f"{function.__name__}-")


class _CacheFile:
    def __init__(self, index: Path) -> None:
        self._index_path = str(index)


class _Dispatcher:
    def __init__(self, index: Path) -> None:
        self._cache = type("Cache", (), {"_cache_file": _CacheFile(index)})()


def test_a_changed_step_source_drops_the_compiled_code_and_a_current_one_keeps_it(
        tmp_path: Path) -> None:
    """A cache stamped with another source fingerprint is deleted and re-stamped; one stamped
    with the current fingerprint is kept."""
    from wholebody_controller import kernels

    index = tmp_path / "whole_step.step_robot-80.py311.nbi"
    data = tmp_path / "whole_step.step_robot-80.py311.1.nbc"
    stamp = tmp_path / "whole_step.step_robot-80.py311.sources"
    other = tmp_path / "whole_step.qp_of_step-120.py311.nbi"
    for path in (index, data, other):
        path.write_bytes(b"machine code")
    stamp.write_text("fingerprint of an older source")
    kernels._drop_stale_cache([_Dispatcher(index)])
    assert not index.exists() and not data.exists() and other.exists()
    current = stamp.read_text()
    assert current != "fingerprint of an older source" and len(current) == 64
    index.write_bytes(b"machine code of the current source")
    kernels._drop_stale_cache([_Dispatcher(index)])
    assert index.exists() and stamp.read_text() == current
