"""Synthetic skins for benchmarks: ``layout.cylinder_taxels`` and ``sim_board.pressed_block``."""

from __future__ import annotations

import numpy as np
import pytest

from skin_driver.layout import TAXEL_PITCH, LayoutError, cylinder_taxels
from skin_driver.protocol import MAX_TAXELS
from skin_driver.sim_board import pressed_block


@pytest.mark.parametrize("count", [1, 50, 2000, MAX_TAXELS + 1000])
def test_cylinder_taxels_lie_on_the_cylinder_with_outward_unit_normals(count: int) -> None:
    radius = 0.06
    positions, normals = cylinder_taxels(count, radius)
    assert positions.shape == normals.shape == (count, 3)
    radial = np.hypot(positions[:, 1], positions[:, 2])
    np.testing.assert_allclose(radial, radius, atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(normals, axis=1), 1.0, atol=1e-12)
    np.testing.assert_allclose(normals[:, 1:] * radius, positions[:, 1:], atol=1e-12)
    assert np.all(normals[:, 0] == 0.0)


def test_cylinder_taxels_beyond_one_layout_do_not_overlap() -> None:
    positions, _ = cylinder_taxels(MAX_TAXELS + 1000)
    # Every pair of taxels at least one pitch apart (checked on a sample against all).
    sample = positions[:: 997]
    d = np.linalg.norm(positions[None, :, :] - sample[:, None, :], axis=2)
    d[d == 0.0] = np.inf
    assert d.min() >= TAXEL_PITCH * 0.99


def test_cylinder_taxels_refuses_no_taxels() -> None:
    with pytest.raises(LayoutError, match="count"):
        cylinder_taxels(0)


def test_pressed_block_presses_one_block_of_the_fraction_above_the_paper_threshold() -> None:
    rng = np.random.default_rng(3)
    forces = pressed_block(2000, 0.1, rng)
    pressed = np.flatnonzero(forces >= 0.1)
    assert pressed.size == 200
    assert np.all(np.diff(pressed) == 1)  # one consecutive block
    rest = np.delete(forces, pressed)
    assert np.all((rest >= 0.0) & (rest < 0.02))
    assert np.all(forces[pressed] < 1.0)


@pytest.mark.parametrize(("count", "fraction"), [(0, 0.1), (10, -0.1), (10, 1.5)])
def test_pressed_block_refuses_bad_arguments(count: int, fraction: float) -> None:
    with pytest.raises(ValueError, match="count ≥ 1 and fraction"):
        pressed_block(count, fraction, np.random.default_rng(0))
