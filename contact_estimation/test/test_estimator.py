"""Contact estimation core against hand-computed cases and an independent per-taxel reference."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from contact_estimation.estimator import (
    ContactEstimator,
    EstimatorConfig,
    GeometryMismatch,
    InvalidTaxelData,
    UnknownPatchError,
    estimate_contact,
)
from phri_common.records import TaxelArray

NO_LIMIT = EstimatorConfig(force_threshold=0.05, torque_limit=(math.inf, math.inf, math.inf))


def flat_grid(nx: int = 10, ny: int = 6, pitch: float = 0.0075) -> tuple[np.ndarray, np.ndarray]:
    """A flat patch in the link's xy-plane at z = 0.05 m, normals +z."""
    xs, ys = np.meshgrid(np.arange(nx) * pitch, np.arange(ny) * pitch, indexing="ij")
    positions = np.stack([xs.ravel(), ys.ravel(), np.full(xs.size, 0.05)], axis=1)
    normals = np.tile([0.0, 0.0, 1.0], (xs.size, 1))
    return positions, normals


def taxels(positions, normals, forces, weights=None, stamp_ns=0) -> TaxelArray:
    return TaxelArray(
        np.asarray(positions, float), np.asarray(normals, float), np.asarray(forces, float),
        None if weights is None else np.asarray(weights, float), "link", stamp_ns,
    )


def test_uniform_patch_has_centre_at_centroid_and_zero_torque() -> None:
    positions, normals = flat_grid()
    state = estimate_contact("link", taxels(positions, normals, np.full(60, 0.5)), NO_LIMIT)
    assert state.in_contact and state.taxel_count == 60
    np.testing.assert_allclose(state.center, positions.mean(axis=0), atol=1e-12)
    np.testing.assert_allclose(state.force, [0.0, 0.0, -30.0], atol=1e-9)  # 60 × 0.5 N into skin
    np.testing.assert_allclose(state.torque, 0.0, atol=1e-12)
    np.testing.assert_allclose(state.region_min, positions.min(axis=0))
    np.testing.assert_allclose(state.region_max, positions.max(axis=0))


def test_contact_on_both_sides_of_a_link_gives_the_hand_computed_torque() -> None:
    # A link along x with radius 0.05 m. Taxel A at x = +0.1 on the +y side pressed with 3 N
    # (force on link −y), taxel B at x = −0.1 on the −y side pressed with 1 N (force +y).
    # Centre = (0, 0, 0). By hand: τ = r_A × f_A + r_B × f_B
    #   r_A × f_A = (0.1, 0.05, 0) × (0, −3, 0) = (0, 0, −0.3)
    #   r_B × f_B = (−0.1, −0.05, 0) × (0, 1, 0) = (0, 0, −0.1)
    # so τ = (0, 0, −0.4) N·m and f = (0, −2, 0) N.
    positions = [[0.1, 0.05, 0.0], [-0.1, -0.05, 0.0]]
    normals = [[0.0, 1.0, 0.0], [0.0, -1.0, 0.0]]
    state = estimate_contact("link", taxels(positions, normals, [3.0, 1.0]), NO_LIMIT)
    np.testing.assert_allclose(state.center, [0.0, 0.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(state.force, [0.0, -2.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(state.torque, [0.0, 0.0, -0.4], atol=1e-12)
    # Swapping the forces flips which side dominates but not the sense of rotation:
    # (0.1, 0.05, 0) × (0, −1, 0) + (−0.1, −0.05, 0) × (0, 3, 0) = (0, 0, −0.1 − 0.3).
    swapped = estimate_contact("link", taxels(positions, normals, [1.0, 3.0]), NO_LIMIT)
    np.testing.assert_allclose(swapped.torque, [0.0, 0.0, -0.4], atol=1e-12)
    np.testing.assert_allclose(swapped.force, [0.0, 2.0, 0.0], atol=1e-12)
    # Mirroring the contact along x reverses the torque.
    mirrored = estimate_contact(
        "link", taxels([[-0.1, 0.05, 0.0], [0.1, -0.05, 0.0]], normals, [3.0, 1.0]), NO_LIMIT
    )
    np.testing.assert_allclose(mirrored.torque, [0.0, 0.0, 0.4], atol=1e-12)


def test_single_taxel_is_its_own_centre_with_zero_torque() -> None:
    positions, normals = flat_grid()
    forces = np.zeros(60)
    forces[17] = 2.0
    state = estimate_contact("link", taxels(positions, normals, forces), NO_LIMIT)
    assert state.taxel_count == 1
    np.testing.assert_allclose(state.center, positions[17])
    np.testing.assert_allclose(state.force, [0.0, 0.0, -2.0])
    np.testing.assert_allclose(state.torque, 0.0, atol=1e-15)
    np.testing.assert_array_equal(state.region_min, state.region_max)


def test_no_taxel_over_threshold_is_the_explicit_no_contact_state() -> None:
    positions, normals = flat_grid()
    state = estimate_contact("link", taxels(positions, normals, np.full(60, 0.01)), NO_LIMIT)
    assert not state.in_contact and state.taxel_count == 0
    assert not state.force.any() and not state.center.any() and not state.torque.any()


def test_force_exactly_at_threshold_is_not_contact_and_just_above_is() -> None:
    positions, normals = flat_grid()
    config = EstimatorConfig(force_threshold=0.2)
    at = estimate_contact("link", taxels(positions, normals, np.full(60, 0.2)), config)
    above = estimate_contact("link", taxels(positions, normals, np.full(60, 0.2001)), config)
    assert not at.in_contact
    assert above.in_contact and above.taxel_count == 60


def test_weights_shift_the_centre_and_scale_the_force() -> None:
    # Two taxels 0.1 m apart, weights 3 and 1: centre at 1/4 of the way from the heavy one.
    positions = [[0.0, 0.0, 0.0], [0.1, 0.0, 0.0]]
    normals = [[0.0, 0.0, 1.0], [0.0, 0.0, 1.0]]
    state = estimate_contact(
        "link", taxels(positions, normals, [1.0, 1.0], weights=[3.0, 1.0]), NO_LIMIT
    )
    np.testing.assert_allclose(state.center, [0.025, 0.0, 0.0])
    np.testing.assert_allclose(state.force, [0.0, 0.0, -4.0])  # (9a): Σ ω f
    # (9b) about the centre: τ_y = Σ (r_z f_x − r_x f_z), r_x = −0.025, 0.075, ω f_z = −3, −1:
    # τ_y = −(−0.025 · −3) − (0.075 · −1) = −0.075 + 0.075 = 0 — balanced about the centre.
    np.testing.assert_allclose(state.torque, [0.0, 0.0, 0.0], atol=1e-12)
    # Weights do not depend on the force: the centre stays put when the forces change.
    heavier = estimate_contact(
        "link", taxels(positions, normals, [5.0, 1.0], weights=[3.0, 1.0]), NO_LIMIT
    )
    np.testing.assert_allclose(heavier.center, state.center)
    # Now ω f_z = −15, −1: τ_y = −(−0.025 · −15) − (0.075 · −1) = −0.375 + 0.075 = −0.3 N·m.
    np.testing.assert_allclose(heavier.torque, [0.0, -0.3, 0.0], atol=1e-12)


def test_torque_limit_clamps_only_the_limited_axis() -> None:
    positions = [[0.1, 0.05, 0.0], [-0.1, -0.05, 0.0]]
    normals = [[0.0, 1.0, 0.0], [0.0, -1.0, 0.0]]
    forces = [30.0, 10.0]  # unlimited τ_z = −(0.2 · 40 / 2) = −4 N·m
    free = estimate_contact("link", taxels(positions, normals, forces), NO_LIMIT)
    np.testing.assert_allclose(free.torque[2], -4.0)
    z_limit = EstimatorConfig(torque_limit=(math.inf, math.inf, 1.2))
    limited = estimate_contact("link", taxels(positions, normals, forces), z_limit)
    np.testing.assert_allclose(limited.torque, [0.0, 0.0, -1.2], atol=1e-12)
    np.testing.assert_allclose(limited.force, free.force)
    # The paper's default limits τ_y (τ(2), 1-based): this τ_z passes unclamped.
    default = estimate_contact("link", taxels(positions, normals, forces), EstimatorConfig())
    np.testing.assert_allclose(default.torque, free.torque, atol=1e-12)


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_non_finite_force_refuses_the_frame(bad: float) -> None:
    positions, normals = flat_grid()
    forces = np.ones(60)
    forces[3] = bad
    with pytest.raises(InvalidTaxelData, match="1 of 60"):
        estimate_contact("link", taxels(positions, normals, forces))


def test_non_finite_position_refuses_the_frame() -> None:
    positions, normals = flat_grid()
    positions[5, 1] = np.nan
    with pytest.raises(InvalidTaxelData, match="position"):
        estimate_contact("link", taxels(positions, normals, np.ones(60)))


def test_negative_forces_are_never_contact() -> None:
    positions, normals = flat_grid()
    forces = -np.ones(60)
    forces[0] = 1.0
    state = estimate_contact("link", taxels(positions, normals, forces))
    assert state.taxel_count == 1


def test_mismatched_sizes_are_refused() -> None:
    # A TaxelArray cannot even hold mismatched sizes; the estimator refuses raw arrays too.
    with pytest.raises(ValueError, match=r"positions must have shape \(5, 3\)"):
        taxels(np.zeros((4, 3)), np.zeros((4, 3)), np.zeros(5))
    with pytest.raises(ValueError, match=r"weights must have shape \(4,\)"):
        taxels(np.zeros((4, 3)), np.zeros((4, 3)), np.zeros(4), np.ones(3))
    with pytest.raises(InvalidTaxelData, match="mismatched"):
        ContactEstimator({"p": "l"}).set_geometry("p", np.zeros((4, 3)), np.zeros((5, 3)))
    est = ContactEstimator({"p": "l"})
    est.set_geometry("p", np.zeros((4, 3)), np.zeros((4, 3)))
    with pytest.raises(InvalidTaxelData, match="4 taxels"):
        est.set_forces("p", np.zeros(3), 0)


def test_unknown_patch_and_refused_frames_leave_other_state_untouched() -> None:
    positions, normals = flat_grid()
    est = ContactEstimator({"upper": "link_a", "fore": "link_b"})
    good = est.update("upper", taxels(positions, normals, np.ones(60), stamp_ns=10))
    with pytest.raises(UnknownPatchError, match="bogus"):
        est.update("bogus", taxels(positions, normals, np.ones(60)))
    bad = np.ones(60)
    bad[0] = np.nan
    with pytest.raises(InvalidTaxelData):
        est.update("upper", taxels(positions, normals, bad, stamp_ns=20))
    kept = est.link_state("link_a")
    assert kept.stamp_ns == 10
    np.testing.assert_allclose(kept.force, good.force)
    assert not est.link_state("link_b").in_contact


def test_invalid_config_is_refused_with_the_parameter_name() -> None:
    with pytest.raises(ValueError, match="force_threshold"):
        EstimatorConfig(force_threshold=math.nan)
    with pytest.raises(ValueError, match="torque_limit"):
        EstimatorConfig(torque_limit=(1.0, -1.0, 1.0))


def reference_estimate(p, n, f, w, threshold):
    """Per-taxel loop straight from eq. (5), (9a), (9b): independent of the vectorised code."""
    contacting = [j for j in range(len(f)) if f[j] > threshold]
    if not contacting:
        return None
    wsum = sum(w[j] for j in contacting)
    centre = sum(w[j] * p[j] for j in contacting) / wsum
    force = sum(w[j] * (-f[j] * n[j]) for j in contacting)
    torque = sum(np.cross(p[j] - centre, w[j] * (-f[j] * n[j])) for j in contacting)
    region = np.array([p[j] for j in contacting])
    return centre, force, torque, region.min(axis=0), region.max(axis=0), len(contacting)


coords = st.floats(-0.5, 0.5, allow_nan=False)


@pytest.mark.parametrize("kernel", ["numba", "numpy"])
@settings(max_examples=60, deadline=None)
@given(data=st.data(), n=st.integers(2, 40), split=st.integers(0, 40))
def test_two_patches_on_one_link_equal_the_per_taxel_reference(
    kernel: str, data: st.DataObject, n: int, split: int
) -> None:
    p = data.draw(arrays(np.float64, (n, 3), elements=coords))
    nrm = data.draw(arrays(np.float64, (n, 3), elements=st.floats(-1, 1)))
    f = data.draw(arrays(np.float64, (n,), elements=st.floats(-1.0, 5.0)))
    w = data.draw(arrays(np.float64, (n,), elements=st.floats(0.1, 3.0)))
    k = 1 + split % (n - 1)  # both patches non-empty: an empty cloud is refused
    est = ContactEstimator({"a": "link", "b": "link"}, replace(NO_LIMIT, kernel=kernel))
    est.update("a", taxels(p[:k], nrm[:k], f[:k], w[:k], stamp_ns=1))
    state = est.update("b", taxels(p[k:], nrm[k:], f[k:], w[k:], stamp_ns=2))
    ref = reference_estimate(p, nrm, f, w, NO_LIMIT.force_threshold)
    if ref is None:
        assert not state.in_contact
        return
    centre, force, torque, low, high, count = ref
    assert state.in_contact and state.stamp_ns == 2 and state.taxel_count == count
    np.testing.assert_allclose(state.center, centre, atol=1e-9)
    np.testing.assert_allclose(state.force, force, atol=1e-9)
    np.testing.assert_allclose(state.torque, torque, atol=1e-9)
    np.testing.assert_array_equal(state.region_min, low)
    np.testing.assert_array_equal(state.region_max, high)


@settings(max_examples=40, deadline=None)
@given(
    data=st.data(),
    shift=arrays(np.float64, (3,), elements=st.floats(-1, 1)),
    limit=st.floats(0.0, 2.0),
)
def test_torque_is_independent_of_the_link_origin_and_respects_the_limit(
    data: st.DataObject, shift: np.ndarray, limit: float
) -> None:
    p = data.draw(arrays(np.float64, (12, 3), elements=coords))
    nrm = data.draw(arrays(np.float64, (12, 3), elements=st.floats(-1, 1)))
    f = data.draw(arrays(np.float64, (12,), elements=st.floats(0.0, 5.0)))
    base = estimate_contact("link", taxels(p, nrm, f), NO_LIMIT)
    moved = estimate_contact("link", taxels(p + shift, nrm, f), NO_LIMIT)
    if base.in_contact:
        np.testing.assert_allclose(moved.center, base.center + shift, atol=1e-9)
        np.testing.assert_allclose(moved.torque, base.torque, atol=1e-9)
    limited = estimate_contact(
        "link", taxels(p, nrm, f), EstimatorConfig(torque_limit=(limit,) * 3)
    )
    assert np.all(np.abs(limited.torque) <= limit + 1e-12)


def test_zero_weight_contact_is_not_a_contact() -> None:
    state = estimate_contact(
        "l", taxels(np.zeros((2, 3)), np.ones((2, 3)), np.ones(2), weights=np.zeros(2))
    )
    assert not state.in_contact


def test_changed_geometry_is_refused_until_announced() -> None:
    positions, normals = flat_grid()
    moved = positions + np.array([1.0, 0.0, 0.0])
    est = ContactEstimator({"p": "l"})
    first = est.update("p", taxels(positions, normals, np.ones(60)))
    with pytest.raises(GeometryMismatch, match="positions, normals or weights differ"):
        est.update("p", taxels(moved, normals, np.ones(60)))
    np.testing.assert_allclose(est.link_state("l").center, first.center)  # nothing stored
    est.forget_geometry("p")  # the announcement: the next frame sets the geometry
    second = est.update("p", taxels(moved, normals, np.ones(60)))
    np.testing.assert_allclose(second.center, first.center + np.array([1.0, 0.0, 0.0]))


@pytest.mark.parametrize("kernel", ["numba", "numpy"])
def test_a_frame_of_another_size_is_refused_and_the_next_good_one_used(kernel: str) -> None:
    positions, normals = flat_grid()
    est = ContactEstimator({"p": "l"}, EstimatorConfig(kernel=kernel))
    est.update("p", taxels(positions, normals, np.full(60, 0.01)))  # no contact
    assert est.taxel_count("p") == 60
    with pytest.raises(GeometryMismatch, match="a frame of 30 taxels, the patch's geometry "
                                               "has 60") as refused:
        est.update("p", taxels(positions[:30], normals[:30], np.ones(30)),
                   check_geometry=False)
    assert (refused.value.patch, refused.value.expected, refused.value.received) == ("p", 60, 30)
    assert est.taxel_count("p") == 60 and not est.link_state("l").in_contact
    with pytest.raises(GeometryMismatch, match="with weights"):
        est.update("p", taxels(positions, normals, np.ones(60), weights=np.ones(60)))
    good = est.update("p", taxels(positions, normals, np.ones(60)), check_geometry=False)
    assert good.taxel_count == 60
    est.forget_geometry()  # every patch: a new size is then taken from the next frame
    assert est.taxel_count("p") is None
    assert est.update("p", taxels(positions[:30], normals[:30], np.ones(30))).taxel_count == 30
    with pytest.raises(UnknownPatchError):
        est.forget_geometry("nowhere")


def test_frames_reusing_the_same_geometry_objects_keep_it_and_still_check_forces() -> None:
    """A composed driver hands over its layout's (read-only) arrays every frame: they are
    taken once; set_geometry in between makes the next such frame's geometry count again."""
    positions, normals = flat_grid()
    est = ContactEstimator({"p": "l"})
    frame = taxels(positions, normals, np.ones(60))
    first = est.update("p", frame)
    for bad in (math.nan, 1e9):
        with pytest.raises(InvalidTaxelData):
            est.update("p", TaxelArray(frame.positions, frame.normals, np.full(60, bad), None,
                                       "link", 1))
    est.set_geometry("p", positions + np.array([1.0, 0.0, 0.0]), normals)
    with pytest.raises(GeometryMismatch):  # the same objects, checked again: not the set ones
        est.update("p", TaxelArray(frame.positions, frame.normals, np.ones(60), None,
                                   "link", 2))
    est.set_geometry("p", positions, normals)
    again = est.update("p", TaxelArray(frame.positions, frame.normals, np.ones(60), None,
                                       "link", 3))
    np.testing.assert_allclose(again.center, first.center)


def test_batched_estimate_matches_one_link_at_a_time() -> None:
    rng = np.random.default_rng(3)
    links = {"a": "l0", "b": "l1", "c": "l0", "d": "l2"}
    est = ContactEstimator(links)
    frames = {}
    for patch in links:
        n = int(rng.integers(5, 30))
        forces = np.where(rng.random(n) < 0.4, rng.uniform(0.1, 2.0, n), 0.0)
        frames[patch] = taxels(rng.normal(size=(n, 3)), rng.normal(size=(n, 3)), forces)
        est.update(patch, frames[patch])
    states = est.estimate()
    for link in ("l0", "l1", "l2"):
        alone = ContactEstimator({p: link for p, lk in links.items() if lk == link})
        for p, lk in links.items():
            if lk == link:
                alone.update(p, frames[p])
        expected = alone.link_state(link)
        assert states[link].taxel_count == expected.taxel_count
        np.testing.assert_allclose(states[link].torque, expected.torque, atol=1e-12)
        np.testing.assert_allclose(states[link].region_max, expected.region_max)


def test_geometry_check_can_be_skipped_but_a_new_taxel_count_is_always_caught() -> None:
    positions, normals = flat_grid()
    est = ContactEstimator({"p": "l"})
    first = est.update("p", taxels(positions, normals, np.ones(60)))
    moved = positions + np.array([1.0, 0.0, 0.0])
    skipped = est.update("p", taxels(moved, normals, np.ones(60)), check_geometry=False)
    np.testing.assert_allclose(skipped.center, first.center)  # not compared: old layout kept
    with pytest.raises(GeometryMismatch):
        est.update("p", taxels(moved, normals, np.ones(60)), check_geometry=True)
    with pytest.raises(GeometryMismatch, match="30 taxels"):
        est.update("p", taxels(moved[:30], normals[:30], np.ones(30)), check_geometry=False)


# --- refusals on every frame ---------------------------------------------------------------


def _f32(positions: np.ndarray, normals: np.ndarray, forces: np.ndarray) -> TaxelArray:
    """A frame as the node decodes it: float32 strided columns of one (N, 7) table."""
    table = np.concatenate([positions, normals, forces[:, None]], axis=1).astype(np.float32)
    return TaxelArray(table[:, 0:3], table[:, 3:6], table[:, 6], None, "link", 0)


@pytest.mark.parametrize("field", ["positions", "normals"])
@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_non_finite_geometry_is_refused_on_every_frame_even_without_geometry_check(
    field: str, bad: float
) -> None:
    positions, normals = flat_grid()
    est = ContactEstimator({"p": "link"})
    good = est.update("p", _f32(positions, normals, np.ones(60)))
    for frame in range(50):
        p, n = positions.copy(), normals.copy()
        (p if field == "positions" else n)[frame % 60, frame % 3] = bad
        with pytest.raises(InvalidTaxelData, match=f"1 of 60 taxel {field}"):
            est.update("p", _f32(p, n, np.full(60, 2.0)), check_geometry=False)
    kept = est.link_state("link")  # nothing of the refused frames was taken
    np.testing.assert_allclose(kept.force, good.force)


def test_huge_but_finite_positions_are_not_a_false_refusal() -> None:
    # float32 sums of these overflow to inf: the cheap test fails, the exact check must clear it.
    positions = np.full((4, 3), 3.0e38)
    normals = np.tile([0.0, 0.0, 1.0], (4, 1))
    state = ContactEstimator({"p": "link"}, NO_LIMIT).update(
        "p", _f32(positions, normals, np.ones(4))
    )
    assert state.in_contact and state.taxel_count == 4


@pytest.mark.parametrize("absurd", [3.0e38, -3.0e38, 1000.001])
def test_force_beyond_the_rated_range_is_refused(absurd: float) -> None:
    positions, normals = flat_grid()
    est = ContactEstimator({"p": "link"})  # default max_taxel_force = 1000 N
    good = est.update("p", _f32(positions, normals, np.ones(60)))
    forces = np.ones(60)
    forces[7] = absurd
    with pytest.raises(InvalidTaxelData, match=r"1 of 60 .*max_taxel_force.*\[-1000, 1000\]"):
        est.update("p", _f32(positions, normals, forces), check_geometry=False)
    with pytest.raises(InvalidTaxelData, match="max_taxel_force"):
        est.set_forces("p", forces, 5)
    np.testing.assert_allclose(est.link_state("link").force, good.force)


def test_force_at_the_rated_range_is_accepted_and_the_bound_is_configurable() -> None:
    positions, normals = flat_grid()
    forces = np.zeros(60)
    forces[0] = 1000.0
    state = ContactEstimator({"p": "link"}).update("p", taxels(positions, normals, forces))
    np.testing.assert_allclose(state.force, [0.0, 0.0, -1000.0])
    strict = ContactEstimator({"p": "link"}, EstimatorConfig(max_taxel_force=50.0))
    with pytest.raises(InvalidTaxelData, match=r"\[-50, 50\]"):
        strict.update("p", taxels(positions, normals, forces))


def test_empty_cloud_is_refused_when_a_geometry_is_known() -> None:
    positions, normals = flat_grid()
    est = ContactEstimator({"p": "link"})
    good = est.update("p", taxels(positions, normals, np.ones(60)))
    for check in (True, False):
        with pytest.raises(InvalidTaxelData, match="empty"):
            est.update("p", taxels(np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0)), check)
    kept = est.link_state("link")
    assert kept.in_contact and kept.taxel_count == good.taxel_count == 60
    with pytest.raises(InvalidTaxelData, match="empty"):
        ContactEstimator({"p": "l"}).update(
            "p", taxels(np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0))
        )


def test_forces_before_any_geometry_are_refused() -> None:
    with pytest.raises(InvalidTaxelData, match="no geometry"):
        ContactEstimator({"p": "l"}).set_forces("p", np.zeros(0), 0)


@pytest.mark.parametrize("value", [math.nan, 0.5, 2.0e6, math.inf])
def test_max_taxel_force_out_of_range_names_parameter_value_and_range(value: float) -> None:
    with pytest.raises(ValueError, match=r"max_taxel_force \[N\] refused value .*\[1, 1e\+06\]"):
        EstimatorConfig(max_taxel_force=value)


def test_a_stuck_skin_is_refused_after_the_timeout_and_recovers_when_it_changes() -> None:
    positions, normals = flat_grid()
    est = ContactEstimator({"p": "l"}, EstimatorConfig(stuck_timeout=0.5))
    pressed = np.zeros(len(positions))
    pressed[:4] = 2.0
    est.update("p", taxels(positions, normals, pressed, stamp_ns=0))
    for k in range(1, 51):  # 0.01 s apart: identical for 0.50 s is still accepted
        est.set_forces("p", pressed, k * 10_000_000)
    with pytest.raises(InvalidTaxelData, match=r"stuck.*0\.51"):
        est.set_forces("p", pressed, 51 * 10_000_000)
    changed = pressed.copy()
    changed[0] += 1e-6  # a real skin's noise: accepted again at once
    est.set_forces("p", changed, 52 * 10_000_000)
    untouched = np.zeros(len(positions))  # an idle skin reading exact zeros is not stuck
    for k in range(53, 200):
        est.set_forces("p", untouched, k * 10_000_000)
