"""Marker throttling on the contact states' clock (contact_estimation.markers.MarkerThrottle)."""

from __future__ import annotations

import math

import pytest

from contact_estimation.markers import MarkerThrottle
from phri_common.contact import ContactState


def _state(t_ms: float, touching: bool = True, link: str = "l") -> ContactState:
    state = ContactState.no_contact(link, round(t_ms * 1e6))
    return ContactState(link=state.link, stamp_ns=state.stamp_ns, in_contact=touching)


def test_rate_limits_each_link_on_state_time() -> None:
    gate = MarkerThrottle(10.0)  # one array per 100 ms
    kept = [t for t in range(0, 1000, 2) if gate.due(_state(t))]
    assert kept == list(range(0, 1000, 100))
    other = MarkerThrottle(10.0)
    assert other.due(_state(0, link="a")) and other.due(_state(1, link="b"))
    assert not other.due(_state(2, link="a"))


def test_contact_start_and_end_always_pass() -> None:
    gate = MarkerThrottle(1.0)
    assert gate.due(_state(0, touching=False))
    assert gate.due(_state(10, touching=True))
    assert not gate.due(_state(20, touching=True))
    assert gate.due(_state(30, touching=False))


def test_zero_rate_passes_everything_and_bad_rates_are_refused() -> None:
    gate = MarkerThrottle(0.0)
    assert all(gate.due(_state(t)) for t in range(10))
    for bad in (-1.0, math.nan, math.inf):
        with pytest.raises(ValueError, match="marker_rate_hz"):
            MarkerThrottle(bad)
