"""MarkerThrottle: markers per link at most at the display rate, contact changes at once."""

from __future__ import annotations

import itertools

import pytest

from contact_estimation.markers import MarkerThrottle


def published(throttle: MarkerThrottle, link: str, contact: list[bool], rate: float) -> list[int]:
    """Indices of the states (one every 1/rate s) whose markers go out."""
    return [k for k, c in enumerate(contact) if throttle.due(link, c, k / rate)]


def test_steady_contact_at_500_hz_gives_at_most_30_marker_arrays_a_second_per_link() -> None:
    throttle = MarkerThrottle(30.0)
    for link in ("a", "b"):
        out = published(throttle, link, [True] * 1000, 500.0)  # 2 s
        # The first state whose age reaches 1/30 s = 16.7 states is every 17th: 59 in 1000.
        assert len(out) == 59
        gaps = {b - a for a, b in itertools.pairwise(out)}
        assert gaps == {17}


def test_contact_made_or_lost_is_published_at_once() -> None:
    throttle = MarkerThrottle(30.0)
    contact = [True] * 5 + [False] * 5 + [True] * 5
    out = published(throttle, "a", contact, 500.0)
    assert out == [0, 5, 10]


def test_rate_zero_publishes_every_state_and_the_rate_can_change() -> None:
    throttle = MarkerThrottle(0.0)
    assert published(throttle, "a", [True] * 50, 500.0) == list(range(50))
    throttle.rate_hz = 100.0
    assert throttle.due("a", True, 10.0) and not throttle.due("a", True, 10.004)
    assert throttle.due("a", True, 10.01)


@pytest.mark.parametrize("rate", [-1.0, float("nan"), float("inf")])
def test_bad_rate_is_refused_naming_the_value(rate: float) -> None:
    with pytest.raises(ValueError, match="marker rate"):
        MarkerThrottle(rate)
