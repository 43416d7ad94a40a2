"""rviz markers for a contact state (pure: message construction only, no rclpy).

Per link, in the link frame, namespace = link name:

* id 0 — sphere at the contact centre ᶦp_η;
* id 1 — force arrow ending at the centre, pointing along ᶦf_η (the push on the link);
* id 2 — torque arrow starting at the centre, along ᶦτ_η;
* id 3 — the contact region Ω_i as a translucent box.

With no contact the four markers are deleted.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from geometry_msgs.msg import Point, Vector3
from std_msgs.msg import ColorRGBA, Header
from visualization_msgs.msg import Marker

from phri_common.records import ContactState
from phri_common.stamps import ns_to_stamp

MARKER_IDS = {"center": 0, "force": 1, "torque": 2, "region": 3}
MIN_REGION_SIZE = 0.002
"""Smallest drawn box edge [m], so a one-taxel region stays visible."""


@dataclass(frozen=True)
class MarkerScales:
    """Arrow lengths per unit: ``force`` [m/N], ``torque`` [m/(N·m)]."""

    force: float = 0.01
    torque: float = 0.1


def _point(v: np.ndarray) -> Point:
    return Point(x=float(v[0]), y=float(v[1]), z=float(v[2]))


def contact_markers(state: ContactState, scales: MarkerScales | None = None) -> list[Marker]:
    """The four markers of one link's contact state (or their deletion when not in contact)."""
    scales = scales or MarkerScales()
    header = Header(stamp=ns_to_stamp(state.stamp_ns), frame_id=state.link)
    if not state.in_contact:
        return [
            Marker(header=header, ns=state.link, id=i, action=Marker.DELETE)
            for i in MARKER_IDS.values()
        ]
    center = state.center
    sphere = Marker(
        header=header, ns=state.link, id=MARKER_IDS["center"], type=Marker.SPHERE,
        action=Marker.ADD, scale=Vector3(x=0.02, y=0.02, z=0.02),
        color=ColorRGBA(r=1.0, g=0.9, b=0.1, a=1.0),
    )
    sphere.pose.position = _point(center)
    sphere.pose.orientation.w = 1.0
    force = Marker(
        header=header, ns=state.link, id=MARKER_IDS["force"], type=Marker.ARROW,
        action=Marker.ADD, scale=Vector3(x=0.006, y=0.012, z=0.015),
        color=ColorRGBA(r=0.9, g=0.1, b=0.1, a=1.0),
        points=[_point(center - scales.force * state.force), _point(center)],
    )
    force.pose.orientation.w = 1.0
    torque = Marker(
        header=header, ns=state.link, id=MARKER_IDS["torque"], type=Marker.ARROW,
        action=Marker.ADD, scale=Vector3(x=0.006, y=0.012, z=0.015),
        color=ColorRGBA(r=0.1, g=0.4, b=1.0, a=1.0),
        points=[_point(center), _point(center + scales.torque * state.torque)],
    )
    torque.pose.orientation.w = 1.0
    size = np.maximum(state.region_max - state.region_min, MIN_REGION_SIZE)
    region = Marker(
        header=header, ns=state.link, id=MARKER_IDS["region"], type=Marker.CUBE,
        action=Marker.ADD, scale=Vector3(x=float(size[0]), y=float(size[1]), z=float(size[2])),
        color=ColorRGBA(r=0.2, g=0.9, b=0.3, a=0.35),
    )
    region.pose.position = _point(0.5 * (state.region_min + state.region_max))
    region.pose.orientation.w = 1.0
    return [sphere, force, torque, region]


class MarkerThrottle:
    """Limits marker arrays to ``rate_hz`` per link on the contact states' own clock.

    Contact states come at the skin rate (500 Hz per patch, ≈ 550 Hz of marker arrays in the
    simulation), far more than a viewer draws. A link's markers go out when its first state
    arrives, when its contact starts or ends (so a released contact is deleted at once), and
    otherwise at most once per 1/``rate_hz`` of state time (``stamp_ns``); 0 = every state.
    """

    def __init__(self, rate_hz: float) -> None:
        self.set_rate(rate_hz)
        self._last: dict[str, tuple[int, bool]] = {}

    def set_rate(self, rate_hz: float) -> None:
        """Change the rate [Hz] (≥ 0; 0 = no throttling).

        Raises:
            ValueError: ``rate_hz`` is negative or not finite.
        """
        if not (np.isfinite(rate_hz) and rate_hz >= 0.0):
            raise ValueError(f"marker_rate_hz must be finite and >= 0 Hz, got {rate_hz}")
        self.period_ns = 0 if rate_hz == 0.0 else round(1e9 / rate_hz)

    def due(self, state: ContactState) -> bool:
        """Whether ``state``'s markers should be published now (and remember it if so)."""
        last = self._last.get(state.link)
        if (last is not None and last[1] == state.in_contact
                and 0 <= state.stamp_ns - last[0] < self.period_ns):
            return False
        self._last[state.link] = (state.stamp_ns, state.in_contact)
        return True
