"""Body-region force limits for physical contact with a person (ISO/TS 15066:2016, Annex A).

ISO/TS 15066 Table A.2 gives, per body region, the maximum permissible *quasi-static* contact
force (the person is pressed or clamped: the force that must never be held) and allows twice that
value for *transient* contact (a short impact, < 0.5 s, where the body can recoil). We keep both
numbers per region; for the head (skull/forehead, face) we take the transient limit equal to the
quasi-static one (no transient allowance), the conservative reading.

These are the limits phri holds a person to: the controller's per-link force limits default to
the region each skin link meets in our scenarios (:data:`SKIN_LINK_REGIONS`), and the simulator
reports the peak force on every body part of the simulated person against its region's limit.
Integrators must re-map the regions to their own application and risk assessment.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class BodyRegion:
    """One ISO/TS 15066 body region.

    Attributes:
        name: region name (Table A.2 wording, snake_case).
        quasi_static: maximum permissible quasi-static force [N].
        transient: maximum permissible transient force [N].
    """

    name: str
    quasi_static: float
    transient: float


def _region(name: str, quasi_static: float, transient_factor: float = 2.0) -> BodyRegion:
    return BodyRegion(name, quasi_static, transient_factor * quasi_static)


BODY_REGIONS: dict[str, BodyRegion] = {
    r.name: r
    for r in (
        _region("skull_forehead", 130.0, 1.0),
        _region("face", 65.0, 1.0),
        _region("neck", 150.0),
        _region("back_shoulders", 210.0),
        _region("chest", 140.0),
        _region("abdomen", 110.0),
        _region("pelvis", 180.0),
        _region("upper_arm_elbow", 150.0),
        _region("lower_arm_wrist", 160.0),
        _region("hand_finger", 140.0),
        _region("thigh_knee", 220.0),
        _region("lower_leg", 130.0),
    )
}
"""ISO/TS 15066:2016 Table A.2, maximum permissible forces by body region."""

SKIN_LINK_REGIONS: dict[str, str] = {
    "left_upper_arm_link": "chest",
    "left_forearm_link": "abdomen",
    "right_forearm_link": "hand_finger",
}
"""The most sensitive region each skin link meets in phri's scenarios: the left forearm holds the
partner's waist (abdomen) in the waltz, the left upper arm can meet the partner's chest when the
couple turns, the right forearm is touched by hands (the other scenarios press every link with a
hand: 140 N, above the abdomen and at the chest value, so these defaults hold there too)."""


def region_of_link(link: str) -> BodyRegion:
    """The body region a skin link's force limits default to.

    Raises:
        KeyError: the link has no mapped region; the message names the mapped links.
    """
    try:
        return BODY_REGIONS[SKIN_LINK_REGIONS[link]]
    except KeyError:
        raise KeyError(f"no ISO/TS 15066 body region mapped for link {link!r}; mapped: "
                       f"{sorted(SKIN_LINK_REGIONS)}") from None
