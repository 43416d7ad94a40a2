"""Random controller configurations and contact sequences the step tests draw from (test-only):
every phase, every contact-safety state, the desired region's window and hysteresis, the lead
moment and carried reference, user references and regions, priority locks, manual desired
forces, force magnitudes from light to far past the limits."""

from __future__ import annotations

import numpy as np
from hypothesis import strategies as st
from wbc_rotations import exp_rotvec
from wbc_tolerances import GAINS

from phri_common.records import ContactState
from wholebody_controller.config import (
    ROBOT_ACCELERATION_LIMITS,
    SKIN_LINKS,
    ControllerConfig,
    LinkTaskConfig,
    dance_ranges,
)
from wholebody_controller.contact_safety import SafetyConfig

Q0 = np.array([0.2, -0.1, 0.4, 0.3, -1.2, 1.5, -1.0, -1.57, 0.0,
               -0.3, -1.9, -1.5, -1.0, 1.57, 0.0])
"""A configuration of both arms clear of their limits and of each other."""
ARM_JOINTS = tuple(f"{side}_{joint}_joint" for side in ("left", "right")
                   for joint in ("shoulder_pan", "shoulder_lift", "elbow", "wrist_1", "wrist_2",
                                 "wrist_3"))
CENTRE = np.array([-0.15, 0.0, 0.05])


def touch_sequence(rng: np.random.Generator, length: int, force_scale: float,
                   dt: float) -> list[dict[str, ContactState]]:
    """Touches and releases per link: a centre that slides, a region that grows and moves,
    force magnitudes from light to far past the limits."""
    steps: list[dict[str, ContactState]] = [{} for _ in range(length)]
    for link in SKIN_LINKS:
        k = int(rng.integers(0, 6))
        while k < length:
            touch = int(rng.integers(3, 40))
            force = rng.normal(size=3) * force_scale * rng.choice([0.05, 0.3, 1.0, 3.0])
            torque = rng.normal(scale=0.5, size=3)
            centre = CENTRE + 0.05 * rng.normal(size=3)
            slide = rng.normal(scale=0.05, size=3) * dt
            half = 0.005 + 0.03 * rng.random(3)
            grow = 0.002 * rng.random(3)
            for j in range(min(touch, length - k)):
                c = centre + j * slide
                w = half + j * grow * (j < 10)
                f = force * (1.0 + 0.2 * np.sin(0.3 * j))
                steps[k + j][link] = ContactState(link, k + j, True, c, f, torque, c - w, c + w,
                                                  12)
            k += touch + int(rng.integers(1, 60))
    return steps


@st.composite
def configs(draw: st.DrawFn) -> ControllerConfig:
    links = []
    for link in SKIN_LINKS:
        reference = None
        if draw(st.integers(0, 5)) == 0:
            rot = exp_rotvec(np.array(draw(st.lists(st.floats(-1, 1), min_size=3, max_size=3))))
            reference = (*rot.ravel().tolist(), 0.1, -0.2, 0.9)
        region = ((-0.3, -0.1, -0.1), (0.0, 0.1, 0.1)) if draw(st.integers(0, 5)) == 0 else None
        limit = draw(st.sampled_from([None, 20.0, 60.0]))
        links.append(LinkTaskConfig(
            link, GAINS[draw(st.integers(0, len(GAINS) - 1))],
            priority_lock=draw(st.sampled_from([None, None, None, 0.3, 1.0])),
            desired_force=draw(st.sampled_from([(0.0, 0.0, 0.0), (0.0, -10.0, 0.0),
                                                (4.0, 0.0, -2.0)])),
            reference=reference, desired_region=region, force_limit=limit,
            transient_force_limit=None if limit is None else 1.5 * limit))
    return ControllerConfig(
        links=tuple(links),
        k_eta=draw(st.sampled_from([0.0, 200.0])),
        b=draw(st.sampled_from([4.0, 40.0])),
        rate_hz=draw(st.sampled_from([100.0, 500.0])),
        region_window=draw(st.sampled_from([0.0, 0.05])),
        region_hysteresis=draw(st.sampled_from([0.0, 0.0075])),
        lead_moment=draw(st.booleans()),
        safety=SafetyConfig(regain_distance=draw(st.sampled_from([0.15, 0.002])),
                            regain_time=draw(st.sampled_from([2.0, 0.05]))),
        acceleration_limits=draw(st.sampled_from(
            [ROBOT_ACCELERATION_LIMITS, (0.5,) * 15, (1e3,) * 15])),
        joint_ranges=dance_ranges(ARM_JOINTS, list(Q0[3:]), 0.1)
        if draw(st.booleans()) else (),
    )


