"""The desired region Ω_d and its track force (region.py): the paper's (10)–(11) when both
deviations are off, the onset window and the face hysteresis when on."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from wholebody_controller.config import ControllerConfig, LinkTaskConfig
from wholebody_controller.region import track_force
from wholebody_controller.task_rows import (
    C_IN,
    C_MAX,
    C_MIN,
    N_CONTACT,
    N_STATE,
    S_BOX,
    S_BOX_SET,
    link_params,
)
from wholebody_controller.task_step import region_track_force, region_update

PITCH = 0.0075  # taxel pitch [m]
LO, HI = (0.16, -0.01, 0.10), (0.20, 0.01, 0.105)

coord = st.floats(-0.3, 0.3)


class DesiredRegion:
    """Ω_d of one link's state row, driven by the step's own functions
    (:func:`region_update`, :func:`region_track_force`)."""

    def __init__(self, margin: float, window: float, hysteresis: float, dt: float) -> None:
        config = ControllerConfig(region_margin=margin, region_window=window,
                                  region_hysteresis=hysteresis, rate_hz=1.0 / dt)
        self.state = np.zeros(N_STATE)
        self.params = link_params(LinkTaskConfig("left_forearm_link"), config)

    def update(self, lo: tuple[float, ...], hi: tuple[float, ...]) -> None:
        contact = np.zeros(N_CONTACT)
        contact[C_IN] = 1.0
        contact[C_MIN : C_MIN + 3], contact[C_MAX : C_MAX + 3] = lo, hi
        region_update(self.state, self.params, contact)

    def track_force(self, lo: tuple[float, ...], hi: tuple[float, ...]) -> tuple[float, ...]:
        return region_track_force(self.state, self.params, tuple(lo), tuple(hi))

    @property
    def box(self) -> tuple[tuple[float, ...], tuple[float, ...]] | None:
        if not self.state[S_BOX_SET]:
            return None
        return tuple(self.state[S_BOX : S_BOX + 3]), tuple(self.state[S_BOX + 3 : S_BOX + 6])


@given(st.tuples(coord, coord, coord), st.tuples(coord, coord, coord),
       st.floats(0.0, 0.05))
def test_without_deviations_it_is_equation_11(a: tuple[float, ...], b: tuple[float, ...],
                                              margin: float) -> None:
    region = DesiredRegion(margin, 0.0, 0.0, 0.01)
    region.update(LO, HI)
    lo = tuple(min(x, y) for x, y in zip(a, b, strict=True))
    hi = tuple(max(x, y) for x, y in zip(a, b, strict=True))
    # (11) written out here: f_R(x⁺ − x_d⁺) − f_R(x_d⁻ − x⁻), Ω_d = Ω at onset ± margin.
    expected = [max(hi[k] - (HI[k] + margin), 0.0) - max((LO[k] - margin) - lo[k], 0.0)
                for k in range(3)]
    np.testing.assert_allclose(region.track_force(lo, hi), expected, atol=1e-15)
    assert region.box is not None
    np.testing.assert_allclose(track_force(lo, hi, *region.box), expected, atol=1e-15)


def _flicker(hysteresis: float) -> list[float]:
    """A still hand whose front boundary taxel flickers over the threshold every other frame,
    the region's +x face two taxel pitches past where Ω_d was locked."""
    region = DesiredRegion(0.01, 0.0, hysteresis, 0.01)
    region.update(LO, HI)
    out = []
    for k in range(200):
        hi = (HI[0] + (2 if k % 2 else 1) * PITCH, HI[1], HI[2])
        out.append(region.track_force(LO, hi)[0])
    return out


def test_a_flickering_boundary_taxel_toggles_the_paper_track_force() -> None:
    mu = np.array(_flicker(0.0))
    assert np.count_nonzero((mu[1:] > 0) != (mu[:-1] > 0)) > 100


def test_one_pitch_of_hysteresis_keeps_it_steady() -> None:
    mu = np.array(_flicker(PITCH))
    assert np.all(mu == 0.0)  # overshoot 2·7.5 − 10 = 5 mm < 7.5 mm: never engages


def test_an_engaged_face_stays_engaged_until_back_inside() -> None:
    region = DesiredRegion(0.01, 0.0, PITCH, 0.01)
    region.update(LO, HI)
    far = (HI[0] + 0.03, HI[1], HI[2])
    assert region.track_force(LO, far)[0] == pytest.approx(0.02)  # engaged: (11) applies
    near = (HI[0] + 0.012, HI[1], HI[2])
    assert region.track_force(LO, near)[0] == pytest.approx(0.002)  # below h, still engaged
    assert region.track_force(LO, HI)[0] == 0.0                    # back inside: off
    assert region.track_force(LO, near)[0] == 0.0                  # and off until > h again


def test_the_onset_window_grows_the_desired_region_then_locks_it() -> None:
    region = DesiredRegion(0.01, 0.05, 0.0, 0.01)
    small_hi = (0.17, 0.0, 0.101)
    region.update(LO, small_hi)           # the first taxels
    for _ in range(4):
        region.update(LO, HI)             # the footprint grows within 0.05 s (5 frames)
    assert region.box is not None and region.box[1][0] == pytest.approx(HI[0] + 0.01)
    for _ in range(10):
        region.update(LO, (0.25, 0.0, 0.11))  # after the window: no more growth
    assert region.box[1][0] == pytest.approx(HI[0] + 0.01)
    assert region.track_force(LO, (0.25, 0.0, 0.105))[0] == pytest.approx(0.04)


@pytest.mark.parametrize(("name", "value"), [("region_window", -1.0),
                                             ("region_hysteresis", float("nan")),
                                             ("region_margin", -0.01)])
def test_bad_settings_are_refused_by_name(name: str, value: float) -> None:
    with pytest.raises(ValueError, match=f"'{name}' .*refused value"):
        ControllerConfig(**{name: value})  # type: ignore[arg-type]
