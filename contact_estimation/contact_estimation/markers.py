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
    """Decides, per link, whether a contact state's markers are published (pure).

    rviz draws at display rate, while contact states come at the skin rate (500 Hz per link):
    markers go out at most ``rate_hz`` times a second per link, except that a change of
    ``in_contact`` (contact made, or lost: its markers are deleted) is always published at once.
    ``rate_hz = 0``: with every contact state.

    Args:
        rate_hz: largest marker rate per link [Hz], ≥ 0.
    """

    def __init__(self, rate_hz: float) -> None:
        self.rate_hz = rate_hz
        self._last: dict[str, tuple[float, bool]] = {}

    @property
    def rate_hz(self) -> float:
        """The marker rate limit per link [Hz] (0 = none)."""
        return self._rate_hz

    @rate_hz.setter
    def rate_hz(self, value: float) -> None:
        if not (value >= 0.0 and np.isfinite(value)):
            raise ValueError(f"marker rate [Hz] refused value {value}: allowed [0, inf)")
        self._rate_hz = float(value)

    def due(self, link: str, in_contact: bool, now_s: float) -> bool:
        """Whether to publish ``link``'s markers for a state at ``now_s`` [s, any clock]."""
        last = self._last.get(link)
        if (
            last is None
            or self._rate_hz == 0.0
            or last[1] != in_contact
            or now_s - last[0] >= 1.0 / self._rate_hz - 1e-9  # exact periods count
        ):
            self._last[link] = (now_s, in_contact)
            return True
        return False
