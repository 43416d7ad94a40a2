"""ISO/TS 15066 body-region limits: the table's values, and a region for every skin link."""

from __future__ import annotations

import pytest

from phri_common.iso15066 import BODY_REGIONS, SKIN_LINK_REGIONS, region_of_link

# ISO/TS 15066:2016 Table A.2, maximum permissible quasi-static force [N], typed from the table.
TABLE_A2 = {"skull_forehead": 130, "face": 65, "neck": 150, "back_shoulders": 210, "chest": 140,
            "abdomen": 110, "pelvis": 180, "upper_arm_elbow": 150, "lower_arm_wrist": 160,
            "hand_finger": 140, "thigh_knee": 220, "lower_leg": 130}


def test_quasi_static_limits_are_table_a2() -> None:
    assert {name: r.quasi_static for name, r in BODY_REGIONS.items()} == TABLE_A2


def test_transient_is_twice_quasi_static_except_the_head() -> None:
    for name, region in BODY_REGIONS.items():
        factor = 1.0 if name in ("skull_forehead", "face") else 2.0
        assert region.transient == factor * TABLE_A2[name], name


def test_skin_links_map_to_regions() -> None:
    # (that every skin link of phri_description is mapped: wholebody_controller's tests)
    assert set(SKIN_LINK_REGIONS.values()) <= set(BODY_REGIONS)
    assert region_of_link("left_forearm_link").quasi_static == 110.0  # the waltz's waist
    with pytest.raises(KeyError, match="mapped"):
        region_of_link("base_link")
