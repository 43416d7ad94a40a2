"""The compiled per-link sums (contact_estimation.patch_sums) against the numpy reference.

Both kernels run on the same randomized patches, links, weights, thresholds and forces; every
link's contact state must agree (flags and counts exactly, vectors to rounding). The numpy
reference itself is checked against hand-computed cases and a per-taxel loop in
test_estimator.py.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from contact_estimation.estimator import (
    ContactEstimator,
    EstimatorConfig,
    InvalidTaxelData,
    UnknownPatchError,
    check_forces,
)
from phri_common.records import CONTACT_VECTORS, TaxelArray


def _pair(patch_links: dict[str, str], threshold: float,
          limit: float) -> tuple[ContactEstimator, ContactEstimator]:
    torque_limit = (limit, limit, limit)
    return tuple(  # type: ignore[return-value]
        ContactEstimator(patch_links, EstimatorConfig(force_threshold=threshold,
                                                      torque_limit=torque_limit, kernel=k))
        for k in ("numpy", "numba")
    )


def _assert_same(reference: ContactEstimator, fused: ContactEstimator) -> None:
    expected, got = reference.estimate(), fused.estimate()
    assert expected.keys() == got.keys()
    for link, want in expected.items():
        have = got[link]
        assert (have.in_contact, have.taxel_count, have.stamp_ns) == (
            want.in_contact, want.taxel_count, want.stamp_ns), link
        for name in CONTACT_VECTORS:
            np.testing.assert_allclose(getattr(have, name), getattr(want, name), rtol=1e-9,
                                       atol=1e-12, err_msg=f"{link}.{name}")
        # The per-link path of update()/link_state() gives the same state as estimate().
        assert fused.link_state(link) == have


@settings(max_examples=60, deadline=None, derandomize=True)
@given(
    seed=st.integers(0, 2**32 - 1),
    n_patches=st.integers(1, 5),
    n_links=st.integers(1, 3),
    weighted=st.booleans(),
    threshold=st.sampled_from([0.0, 0.05, 0.5, 2.0]),
    limit=st.sampled_from([math.inf, 0.05]),
    frames=st.integers(1, 4),
)
def test_fused_kernel_matches_numpy_reference(seed: int, n_patches: int, n_links: int,
                                              weighted: bool, threshold: float, limit: float,
                                              frames: int) -> None:
    rng = np.random.default_rng(seed)
    patch_links = {f"p{i}": f"link{rng.integers(n_links)}" for i in range(n_patches)}
    reference, fused = _pair(patch_links, threshold, limit)
    for patch in patch_links:
        n = int(rng.integers(1, 300))
        positions = rng.uniform(-0.3, 0.3, (n, 3))
        normals = rng.normal(size=(n, 3))
        normals /= np.linalg.norm(normals, axis=1, keepdims=True)
        weights = rng.uniform(0.0, 2.0, n) if weighted and rng.random() < 0.7 else None
        for est in (reference, fused):
            est.set_geometry(patch, positions, normals, weights)
    for frame in range(frames):
        for patch in patch_links:
            if rng.random() < 0.3:
                continue  # some patches keep their previous frame
            n = reference._columns[patch][1] - reference._columns[patch][0]
            # Mostly below the threshold, a pressed part above it, some exactly at it.
            forces = rng.uniform(-0.2, 0.2, n)
            pressed = rng.random(n) < rng.uniform(0.0, 0.5)
            forces[pressed] = rng.uniform(0.0, 20.0, int(pressed.sum()))
            forces[rng.random(n) < 0.05] = threshold
            for est in (reference, fused):
                est.set_forces(patch, forces, stamp_ns=1000 * frame + 1)
        _assert_same(reference, fused)


def test_unknown_kernel_is_refused_with_the_allowed_values() -> None:
    with pytest.raises(ValueError, match=r"kernel refused value 'fortran'.*numba.*numpy"):
        EstimatorConfig(kernel="fortran")


@settings(max_examples=50, deadline=None, derandomize=True)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(1, 500), same=st.booleans(),
       float32=st.booleans())
def test_scan_frame_matches_the_numpy_checks(seed: int, n: int, same: bool,
                                             float32: bool) -> None:
    from contact_estimation.patch_sums import scan_frame

    rng = np.random.default_rng(seed)
    forces = rng.uniform(-30.0, 30.0, n).astype(np.float32 if float32 else np.float64)
    forces[rng.random(n) < 0.5] = 0.0
    previous = forces.astype(np.float64)
    if not same:
        previous[rng.integers(n)] += 1e-3
    threshold = float(rng.choice([0.0, 10.0, 29.0, 40.0]))
    norm2, unchanged, first, last = scan_frame(forces, previous, threshold)
    # The reference range check's ‖f‖² (its dot product rounds in the array's precision).
    assert norm2 == pytest.approx(check_forces(forces, 1e6), rel=1e-6 if float32 else 1e-12)
    assert unchanged == np.array_equal(forces, previous)
    hot = np.flatnonzero(forces > threshold)
    assert (first, last) == ((hot[0], hot[-1]) if hot.size else (n, -1))


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf, 1e200])
def test_norm2_of_a_bad_frame_fails_the_range_test(bad: float) -> None:
    """Summed in any order (vectorised), ‖f‖² still propagates NaN/Inf and overflows."""
    from contact_estimation.patch_sums import scan_frame

    forces = np.full(37, 0.5)
    forces[17] = bad
    norm2, *_ = scan_frame(forces, np.zeros(37), 0.05)
    assert not norm2 <= 1e12


def _frame(rng: np.random.Generator, n: int, threshold: float, kind: str,
           max_force: float) -> np.ndarray:
    """One patch frame [N] of ``kind``: a pressed area, or a frame that is to be refused
    (NaN/Inf, beyond the range), or many forces within the range whose norm is beyond it."""
    forces = rng.uniform(-0.2, 0.2, n)
    pressed = rng.random(n) < rng.uniform(0.0, 0.5)
    forces[pressed] = rng.uniform(0.0, min(20.0, max_force), int(pressed.sum()))
    forces[rng.random(n) < 0.05] = threshold
    if kind == "nan":
        forces[rng.integers(n)] = rng.choice([math.nan, math.inf, -math.inf])
    elif kind == "over":
        forces[rng.integers(n)] = max_force * rng.uniform(1.001, 10.0) * rng.choice([-1, 1])
    elif kind == "loud":  # every force within the range, ‖f‖ beyond it: accepted
        forces[:] = max_force * rng.uniform(0.5, 1.0, n)
    return forces


def _same_outcome(ests: tuple[ContactEstimator, ...], action: str, *args: object) -> None:
    """Both estimators take the same call: both succeed or both refuse with one message."""
    outcomes = []
    for est in ests:
        try:
            getattr(est, action)(*args)
            outcomes.append(None)
        except (InvalidTaxelData, UnknownPatchError) as err:
            outcomes.append((type(err), str(err)))
    assert outcomes[0] == outcomes[1], action


@settings(max_examples=60, deadline=None, derandomize=True)
@given(seed=st.integers(0, 2**32 - 1), n_patches=st.integers(1, 4),
       n_links=st.integers(1, 3), weighted=st.booleans(), steps=st.integers(1, 25))
def test_kernels_agree_on_frame_sequences_with_refusals_and_changes(
        seed: int, n_patches: int, n_links: int, weighted: bool, steps: int) -> None:
    """Random sequences of frames: pressed, NaN/Inf, beyond the rated range, loud but within it,
    repeated (a stuck skin), float32 (a decoded message), through ``set_forces`` and ``update``,
    with new geometry and a new threshold on the way. After every call the numba estimator
    (per-patch sums kept at frame time) refuses exactly what the numpy reference refuses, with
    the same message, and every link's state agrees."""
    rng = np.random.default_rng(seed)
    patch_links = {f"p{i}": f"link{rng.integers(n_links)}" for i in range(n_patches)}
    max_force = float(rng.choice([1.0, 30.0, 1000.0]))
    config = EstimatorConfig(force_threshold=0.05, max_taxel_force=max_force, stuck_timeout=0.02,
                             torque_limit=(math.inf, 0.5, math.inf))
    ests = tuple(ContactEstimator(patch_links, replace(config, kernel=k))
                 for k in ("numpy", "numba"))
    geometry: dict[str, tuple[np.ndarray, ...]] = {}
    last: dict[str, np.ndarray] = {}

    def new_geometry(patch: str) -> None:
        n = int(rng.integers(1, 200))
        positions = rng.uniform(-0.3, 0.3, (n, 3))
        normals = rng.normal(size=(n, 3))
        normals /= np.linalg.norm(normals, axis=1, keepdims=True)
        weights = rng.uniform(0.0, 2.0, n) if weighted and rng.random() < 0.7 else None
        geometry[patch] = (positions, normals, weights)
        last.pop(patch, None)
        for est in ests:
            est.set_geometry(patch, positions, normals, weights)

    for patch in patch_links:
        new_geometry(patch)
    for step in range(steps):
        stamp = 10_000_000 * (step + 1)  # 10 ms apart: a third repeat is stuck
        patch = f"p{rng.integers(n_patches)}"
        action = rng.choice(["frame", "frame", "frame", "repeat", "geometry", "threshold"])
        if action == "geometry":
            new_geometry(patch)
        elif action == "threshold":
            threshold = float(rng.choice([0.0, 0.05, 0.5, 2.0]))
            for est in ests:
                est.reconfigure(replace(est.config, force_threshold=threshold))
        else:
            n = geometry[patch][0].shape[0]
            kind = rng.choice(["pressed", "pressed", "nan", "over", "loud"])
            forces = (last[patch] if action == "repeat" and patch in last else
                      _frame(rng, n, ests[0].config.force_threshold, kind, max_force))
            last[patch] = forces
            if rng.random() < 0.3:
                forces = forces.astype(np.float32)
            if rng.random() < 0.5:
                _same_outcome(ests, "set_forces", patch, forces, stamp)
            else:
                frame = TaxelArray(*geometry[patch][:2], forces, geometry[patch][2], "l", stamp)
                _same_outcome(ests, "update", patch, frame)
        _assert_same(*ests)


@settings(max_examples=50, deadline=None, derandomize=True)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(1, 300),
       bad=st.sampled_from([None, math.nan, math.inf, -math.inf]),
       field=st.integers(0, 5), float32=st.booleans())
def test_geometry_total_is_finite_exactly_when_every_element_is(
        seed: int, n: int, bad: float | None, field: int, float32: bool) -> None:
    """On the columns of a decoded message's (N, 7) float32 table, as the node hands them over,
    and on float64 arrays: one bad position or normal component makes the total non-finite."""
    from contact_estimation.patch_sums import geometry_total

    rng = np.random.default_rng(seed)
    table = rng.uniform(-1.0, 1.0, (n, 7)).astype(np.float32 if float32 else np.float64)
    if bad is not None:
        table[rng.integers(n), field] = bad
    total = geometry_total(table[:, 0:3], table[:, 3:6])
    assert math.isfinite(total) == bool(np.isfinite(table[:, 0:6]).all())
    assert total == pytest.approx(float(table[:, 0:6].sum(dtype=np.float64)), rel=1e-9,
                                  abs=1e-3) or bad is not None
