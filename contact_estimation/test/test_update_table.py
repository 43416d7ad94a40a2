"""ContactEstimator.update_table (a decoded message's taxel table, the node's input path)
against update on the same frames with the numpy kernel, the tests' oracle.

The numba estimator takes each frame as phri's read-only float32 table (N, 7 or 8), mostly
through the one-pass compiled path (``check_geometry=False``), the reference takes the table's
columns as a TaxelArray through ``update``: both must refuse the same frames with the same
message and give the same states, frame after frame (NaN/Inf geometry, weights and forces, a
force beyond the rated range, a stuck skin, a new taxel count, an empty cloud).
"""

from __future__ import annotations

import math
from collections.abc import Callable
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
)
from phri_common.records import CONTACT_VECTORS, ContactState, TaxelArray

MAX_FORCE = 30.0
CONFIG = EstimatorConfig(force_threshold=0.05, max_taxel_force=MAX_FORCE, stuck_timeout=0.02,
                         torque_limit=(math.inf, 0.5, math.inf))


def _table(rng: np.random.Generator, n: int, weighted: bool) -> np.ndarray:
    """A writable float32 taxel table: positions, unit normals, a pressed area (, weights)."""
    table = np.empty((n, 8 if weighted else 7), dtype=np.float32)
    table[:, 0:3] = rng.uniform(-0.3, 0.3, (n, 3))
    normals = rng.normal(size=(n, 3))
    table[:, 3:6] = normals / np.linalg.norm(normals, axis=1, keepdims=True)
    table[:, 6] = np.where(rng.random(n) < 0.3, rng.uniform(0.0, 20.0, n),
                           rng.uniform(-0.2, 0.2, n))
    if weighted:
        table[:, 7] = rng.uniform(0.0, 2.0, n)
    return table


def _frozen(table: np.ndarray) -> np.ndarray:
    """A read-only copy, as a decoded message's view of its bytes."""
    out = np.frombuffer(table.tobytes(), dtype=table.dtype).reshape(table.shape)
    assert not out.flags.writeable
    return out


def _columns(table: np.ndarray, stamp: int) -> TaxelArray:
    weights = table[:, 7] if table.shape[1] > 7 else None
    return TaxelArray(table[:, 0:3], table[:, 3:6], table[:, 6], weights, "l", stamp)


def _outcome(method: Callable[..., ContactState], *args: object) -> tuple[type, str] | ContactState:
    try:
        return method(*args)
    except (InvalidTaxelData, UnknownPatchError) as err:
        return type(err), str(err)


def _assert_same_state(have: object, want: object) -> None:
    assert type(have) is type(want)
    if not isinstance(want, ContactState):
        assert have == want  # the same refusal, word for word
        return
    assert isinstance(have, ContactState)
    assert (have.link, have.stamp_ns, have.in_contact, have.taxel_count) == (
        want.link, want.stamp_ns, want.in_contact, want.taxel_count)
    for name in CONTACT_VECTORS:
        np.testing.assert_allclose(getattr(have, name), getattr(want, name), rtol=1e-9,
                                   atol=1e-12, err_msg=name)


def _spoil(rng: np.random.Generator, table: np.ndarray, kind: str) -> None:
    """Make ``table`` a frame to be refused (or, "loud", one to be accepted)."""
    j = int(rng.integers(table.shape[0]))
    bad = rng.choice([math.nan, math.inf, -math.inf])
    if kind == "bad_geometry":  # a position or normal component
        table[j, int(rng.integers(6))] = bad
    elif kind == "bad_weight" and table.shape[1] > 7:
        table[j, 7] = bad
    elif kind == "bad_force":
        table[j, 6] = bad
    elif kind == "over":
        table[j, 6] = MAX_FORCE * rng.uniform(1.001, 10.0) * rng.choice([-1, 1])
    elif kind == "loud":  # every force within the range, ‖f‖ beyond it: accepted
        table[:, 6] = MAX_FORCE * rng.uniform(0.5, 1.0, table.shape[0])


@settings(max_examples=60, deadline=None, derandomize=True)
@given(seed=st.integers(0, 2**32 - 1), n_patches=st.integers(1, 3),
       weighted=st.booleans(), steps=st.integers(1, 30))
def test_update_table_matches_update_of_the_numpy_reference(
        seed: int, n_patches: int, weighted: bool, steps: int) -> None:
    rng = np.random.default_rng(seed)
    links = {f"p{i}": f"link{i % 2}" for i in range(n_patches)}
    reference = ContactEstimator(links, replace(CONFIG, kernel="numpy"))
    fused = ContactEstimator(links, CONFIG)
    assert fused.config.kernel == "numba"
    tables = {p: _table(rng, int(rng.integers(1, 120)), weighted) for p in links}
    for step in range(steps):
        stamp = 10_000_000 * (step + 1)  # 10 ms apart: a third repeat is stuck
        patch = f"p{rng.integers(n_patches)}"
        action = rng.choice(["frame", "frame", "frame", "repeat", "repeat", "resize",
                             "empty", "spoil", "spoil", "unknown"])
        table = tables[patch]
        if action == "frame":  # new forces, the same geometry
            table = tables[patch] = table.copy()
            table[:, 6] = _table(rng, table.shape[0], weighted)[:, 6]
        elif action == "resize":
            table = tables[patch] = _table(rng, int(rng.integers(1, 120)), weighted)
        elif action == "empty":
            table = table[:0]
        elif action == "spoil":
            table = table.copy()
            _spoil(rng, table, str(rng.choice(["bad_geometry", "bad_weight", "bad_force",
                                               "over", "loud"])))
        elif action == "unknown":
            patch = "nowhere"
        frame = _frozen(table)
        check = bool(rng.random() < 0.2)
        want = _outcome(reference.update, patch, _columns(frame, stamp), check)
        have = _outcome(fused.update_table, patch, frame, stamp, check)
        _assert_same_state(have, want)
        for link in set(links.values()):
            _assert_same_state(fused.link_state(link), reference.link_state(link))


def test_a_stuck_table_is_refused_and_a_table_of_another_shape_names_it() -> None:
    rng = np.random.default_rng(3)
    est = ContactEstimator({"p": "l"}, CONFIG)
    frame = _frozen(_table(rng, 50, weighted=False))
    est.update_table("p", frame, 0)
    est.update_table("p", frame, 10_000_000, check_geometry=False)
    with pytest.raises(InvalidTaxelData, match="stuck"):
        est.update_table("p", frame, 30_000_000, check_geometry=False)
    with pytest.raises(InvalidTaxelData, match=r"\(N, 7\) or \(N, 8\), got \(50, 6\)"):
        est.update_table("p", frame[:, 0:6], 40_000_000)


def test_one_pass_kernel_writes_nothing_for_non_finite_geometry() -> None:
    """take_table refuses a frame with a NaN position before it stores its forces or sums."""
    from contact_estimation import patch_sums

    rng = np.random.default_rng(4)
    table = _table(rng, 20, weighted=False)
    table[7, 1] = math.nan
    stored, sums = np.full(21, 0.25), np.full((1, 16), 0.5)
    out, counts = np.full((1, patch_sums.STATE_WIDTH), 0.75), np.full(1, 9, dtype=np.int64)
    rows = rng.uniform(size=(20, 9))
    total, norm2, _ = patch_sums.take_table(_frozen(table), stored, rows, 0, 0.05, 1e6, sums, 0,
                                       np.array([0, 1]), np.ones(3), 0, out, counts)
    assert math.isnan(total) and math.isnan(norm2)
    assert (stored == 0.25).all() and (sums == 0.5).all() and (out == 0.75).all()
    assert counts[0] == 9
