"""The paper's values, typed here from the paper (Table II, Sec. III-A, VI) as an oracle
independent of phri_common.paper: changing a value in the single source fails this test."""

from __future__ import annotations

import math

from phri_common import paper


def _diagonals(gains: paper.Admittance) -> tuple[tuple[float, ...], ...]:
    return gains.inertia, gains.damping, gains.stiffness


def test_table_ii() -> None:
    # | q̇_l | q̇_u | q_l | q_u | k_η | b | K_p | ψ_thr |  →  −0.15, 0.15, −∞, +∞, 200, 4, 5, 10⁻⁴
    assert paper.VELOCITY_LIMIT == 0.15
    assert paper.K_ETA == 200.0
    assert paper.B == 4.0
    assert paper.K_P == 5.0
    assert paper.PSI_THR == 1e-4


def test_section_vi_opening_and_skin_rate() -> None:
    assert paper.CONTROL_RATE_HZ == 100.0  # "with a control frequency of 100 Hz"
    assert paper.FILTER_WINDOW == 10  # "moving average filter with a window size of 10"
    assert isinstance(paper.FILTER_WINDOW, int)
    assert paper.EPSILON == 0.1  # "ε and h ... manually set to 0.1 and 0.15"
    assert paper.HORIZON == 0.15
    assert paper.SKIN_RATE_HZ == 500.0  # III-A: "at a frequency of 500 Hz"


def test_basic_experiments() -> None:
    assert _diagonals(paper.CENTRING) == ((0.5,) * 6, (40.0,) * 6, (0.0,) * 6)
    assert paper.TORQUE_LIMIT[1] == 1.2  # τ(2), 1-based: the axis Fig. 6b shows clamped
    assert math.isinf(paper.TORQUE_LIMIT[0]) and math.isinf(paper.TORQUE_LIMIT[2])
    assert _diagonals(paper.TRACKING) == (
        (0.5,) * 6, (40.0, 40.0, 500.0, 40.0, 40.0, 40.0), (0.0,) * 6)
    assert paper.REGION_MARGIN == 0.01
    assert _diagonals(paper.WHOLE_BODY) == ((0.5,) * 6, (60.0,) * 6, (40.0,) * 6)


def test_waltz() -> None:
    assert _diagonals(paper.WALTZ) == ((0.1,) * 6, (200.0,) * 6, (0.0,) * 6)
    assert paper.Q_DANCE_HALF_WIDTH == 0.1
    assert paper.WALTZ_DESIRED_FORCE == 10.0
    assert paper.WALTZ_PRIORITY_LOCK == 1.0


def test_six_is_a_scaled_identity_diagonal() -> None:
    assert paper.six(2.5) == (2.5, 2.5, 2.5, 2.5, 2.5, 2.5)
