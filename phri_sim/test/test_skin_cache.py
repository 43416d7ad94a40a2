"""Cached candidate taxels of the footprint model are exact (skin.SkinPatchModel), and the
bridge's taxel publication rate is checked against the skin period."""

from __future__ import annotations

import numpy as np
import pytest

from phri_description.description import robot_description
from phri_sim.ros.bridge import _publish_steps
from phri_sim.world.skin_footprint import (
    CapsuleShape,
    Shape,
    SkinPatchModel,
    SphereShape,
    layout_for_patch,
)


def _path(kind: str, k: int) -> Shape:
    """A shape sliding 1 mm per sample along and around the forearm patch, sinking in and out."""
    s = 0.001 * k
    depth = 0.003 * np.sin(0.05 * k)
    if kind == "sphere":
        return SphereShape(np.array([0.05 + s, 0.0, 0.045 + 0.045 - depth]), 0.045)
    a = np.array([0.05 + s, -0.15, 0.045 + 0.06 - depth])
    return CapsuleShape(a, a + np.array([0.02, 0.3, 0.0]), 0.06)


@pytest.mark.parametrize("kind", ["sphere", "capsule"])
def test_cached_candidates_give_the_same_forces_as_a_full_search(kind: str) -> None:
    layout = layout_for_patch(robot_description().patch("right_forearm"))
    cached, full = SkinPatchModel(layout), SkinPatchModel(layout)
    rot, pos = np.eye(3), np.zeros(3)
    lit = 0
    for k in range(200):
        shape = _path(kind, k)
        a = cached.forces(rot, pos, [(shape, 10.0)], keys=[7])
        b = full.forces(rot, pos, [(shape, 10.0)])
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-12)
        lit += int(np.count_nonzero(a))
    assert lit > 200  # the shape did press on the patch along the way


def test_publication_rate_must_be_whole_skin_periods() -> None:
    assert _publish_steps(0.0, 1, 0.002) == 1
    assert _publish_steps(100.0, 1, 0.002) == 5
    with pytest.raises(ValueError, match="taxel_publish_rate_hz"):
        _publish_steps(250.0, 5, 0.002)  # 4 ms publication, 10 ms skin period
