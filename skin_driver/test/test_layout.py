"""Layout generators (geometry from first principles) and the layout file."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from skin_driver.layout import (
    TAXEL_PITCH,
    LayoutError,
    SkinLayout,
    cylindrical_patch,
    load_layout,
    rectangular_patch,
    save_layout,
)


def _nearest_distances(p: np.ndarray) -> np.ndarray:
    d = np.linalg.norm(p[:, None, :] - p[None, :, :], axis=2)
    np.fill_diagonal(d, np.inf)
    return d.min(axis=1)


def test_rectangular_patch_geometry() -> None:
    center = np.array([0.1, -0.02, 0.05])
    lay = rectangular_patch("p", "l", rows=4, cols=6, center=center,
                            col_axis=(0, 1, 0), row_axis=(0, 0, 1))
    assert lay.size == 24
    np.testing.assert_allclose(lay.positions.mean(axis=0), center, atol=1e-12)
    np.testing.assert_allclose(_nearest_distances(lay.positions), 0.0075, rtol=1e-12)
    np.testing.assert_allclose(lay.normals, np.tile([1.0, 0.0, 0.0], (24, 1)))  # y × z = x
    # Row-major order: taxel 1 is one pitch along the column axis from taxel 0.
    np.testing.assert_allclose(lay.positions[1] - lay.positions[0], [0, 0.0075, 0], atol=1e-15)
    np.testing.assert_allclose(lay.positions[6] - lay.positions[0], [0, 0, 0.0075], atol=1e-15)
    # Extent: (cols - 1) pitches along the row.
    assert np.ptp(lay.positions[:, 1]) == pytest.approx(5 * 0.0075)


def test_cylindrical_patch_geometry() -> None:
    r = 0.05
    point = np.array([0.01, 0.02, 0.0])
    axis = np.array([1.0, 1.0, 0.0]) / math.sqrt(2)
    lay = cylindrical_patch("arm", "forearm", r, (0.0, 0.1), axis_point=point, axis=axis)
    # 2π·0.05 / 0.0075 = 41.9 → 41 taxels per ring; 0.1 / 0.0075 = 13.3 → 13 rings.
    assert lay.size == 41 * 13
    rel = lay.positions - point
    s = rel @ axis
    radial = rel - s[:, None] * axis
    np.testing.assert_allclose(np.linalg.norm(radial, axis=1), r, rtol=1e-12)
    np.testing.assert_allclose(lay.normals, radial / r, atol=1e-12)  # outward radial
    rings = np.unique(np.round(s, 9))
    np.testing.assert_allclose(np.diff(rings), TAXEL_PITCH, rtol=1e-9)
    assert rings.mean() == pytest.approx(0.05)  # centred in the axial range
    # Arc pitch within a ring ≥ the taxel size (squares do not overlap) and < 2 pitches.
    arc = 2 * math.pi * r / 41
    assert TAXEL_PITCH <= arc < 2 * TAXEL_PITCH
    np.testing.assert_allclose(_nearest_distances(lay.positions[:41]),
                               2 * r * math.sin(math.pi / 41), rtol=1e-9)


def test_cylindrical_partial_arc_and_reference() -> None:
    lay = cylindrical_patch("half", "l", 0.04, (0.0, 0.0075), angle_range=(0.0, math.pi),
                            reference=(1, 0, 0))
    # π·0.04 / 0.0075 = 16.76 → 16 taxels, one ring, at angles (m + ½)·π/16 from +x.
    assert lay.size == 16
    angles = np.arctan2(lay.positions[:, 1], lay.positions[:, 0])
    np.testing.assert_allclose(angles, (np.arange(16) + 0.5) * math.pi / 16, atol=1e-12)
    assert np.all(lay.positions[:, 1] > 0)  # only the +y half


@pytest.mark.parametrize(
    "call",
    [
        lambda: rectangular_patch("p", "l", 0, 3),
        lambda: rectangular_patch("p", "l", 2, 2, col_axis=(1, 0, 0), row_axis=(2, 0, 0)),
        lambda: rectangular_patch("p", "l", 2, 2, pitch=float("nan")),
        lambda: cylindrical_patch("p", "l", -0.1, (0, 1)),
        lambda: cylindrical_patch("p", "l", 0.1, (1, 0)),
        lambda: cylindrical_patch("p", "l", 0.1, (0, 1), angle_range=(0, 7)),
        lambda: cylindrical_patch("p", "l", 0.1, (0, 1), reference=(0, 0, 2)),
        lambda: SkinLayout("p", "l", np.full((2, 3), np.nan), np.ones((2, 3))),
        lambda: SkinLayout("p", "l", np.zeros((2, 3)), np.zeros((2, 3))),
        lambda: SkinLayout("p", "l", np.zeros((2, 3)), np.ones((2, 3)), gains=np.array([1, -1])),
    ],
)
def test_bad_geometry_is_refused(call) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(LayoutError):
        call()


def test_layout_file_round_trip(tmp_path: Path) -> None:
    base = cylindrical_patch("left_forearm", "left_forearm_link", 0.045, (0.02, 0.3))
    n = base.size
    rng = np.random.default_rng(1)
    lay = SkinLayout(base.patch, base.link, base.positions, base.normals,
                     weights=rng.uniform(0.5, 2, n), gains=rng.uniform(4e-4, 6e-4, n),
                     offsets=rng.integers(900, 1100, n).astype(float),
                     dead=rng.random(n) < 0.05)
    path = tmp_path / "left_forearm.yaml"
    save_layout(lay, path)
    text = path.read_text()
    assert text.startswith("# phri skin layout") and "link: left_forearm_link" in text
    back = load_layout(path)
    assert (back.patch, back.link, back.size) == (lay.patch, lay.link, n)
    np.testing.assert_allclose(back.positions, lay.positions, atol=5e-7)  # µm in the file
    np.testing.assert_allclose(back.normals, lay.normals, atol=2e-6)
    assert back.weights is not None and back.gains is not None and back.offsets is not None
    np.testing.assert_allclose(back.weights, lay.weights, rtol=1e-8)
    np.testing.assert_allclose(back.gains, lay.gains, rtol=1e-8)
    np.testing.assert_array_equal(back.offsets, lay.offsets)
    np.testing.assert_array_equal(back.dead, lay.dead)


def test_geometry_only_file_and_ten_thousand_taxels(tmp_path: Path) -> None:
    lay = rectangular_patch("big", "link", 100, 100)
    path = tmp_path / "big.yaml"
    save_layout(lay, path)
    back = load_layout(path)
    assert back.size == 10_000
    assert back.weights is None and back.gains is None and back.dead is None
    np.testing.assert_allclose(back.positions, lay.positions, atol=5e-7)


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (lambda t: t.replace("version: 1", "version: 2"), "version"),
        (lambda t: t.replace("format: phri_skin_layout", "format: other"), "not a"),
        (lambda t: t.replace("taxel_count: 4", "taxel_count: 5"), "expected taxel_count"),
        (lambda t: t.replace(", normal_z]", "]"), "missing"),
        (lambda t: t.replace("0.000000 0.000000 1.000000", "0.000000 0.000000 nan", 1),
         "non-finite"),
        (lambda t: t.replace("0.000000 0.000000 1.000000", "0.000000 0.000000 x", 1),
         "non-numeric"),
        (lambda t: "key: [unclosed\n" + t, "cannot read"),
    ],
)
def test_malformed_file_gives_a_clear_error(tmp_path: Path, edit, message: str) -> None:  # type: ignore[no-untyped-def]
    path = tmp_path / "bad.yaml"
    save_layout(rectangular_patch("p", "l", 2, 2), path)
    text = path.read_text()
    path.write_text(edit(text))
    with pytest.raises(LayoutError, match=message) as info:
        load_layout(path)
    assert "bad.yaml" in str(info.value)
