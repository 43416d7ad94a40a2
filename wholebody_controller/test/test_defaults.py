"""The controller's defaults are the paper's (Table II, Sec. VI), typed here from the paper, and
the node's parameter defaults build exactly the default configuration."""

from __future__ import annotations

import pytest

from phri_description.description import JOINT_NAMES
from wholebody_controller.config import (
    CONTACT_CENTRING,
    CONTACT_TRACKING,
    WALTZ,
    WHOLE_BODY,
    AdmittanceGains,
    ControllerConfig,
    dance_ranges,
)
from wholebody_controller.parameters import GLOBAL_PARAMS, PARAMS, config_from_values

PAPER = {  # Table II, Sec. VI opening, VI-A.2
    "velocity_limit": 0.15, "k_eta": 200.0, "b": 4.0, "k_p": 5.0, "psi_thr": 1e-4,
    "epsilon": 0.1, "horizon": 0.15, "rate_hz": 100.0, "region_margin": 0.01,
}


def test_config_defaults_are_the_paper_values() -> None:
    config = ControllerConfig()
    for name, value in PAPER.items():
        assert getattr(config, name) == value, name
    assert config.solver == "daqp"
    for task in config.links:  # VI-A.1 centring set by default
        assert task.admittance.inertia == (0.5,) * 6
        assert task.admittance.damping == (40.0,) * 6
        assert task.admittance.stiffness == (0.0,) * 6


def test_parameter_defaults_are_the_paper_values() -> None:
    defaults = {s.name: s.default for s in GLOBAL_PARAMS}
    for name, value in PAPER.items():
        assert defaults[name] == value, name
    assert defaults["q_dance_range"] == 0.1  # VI-B: q_dance ∓ 0.1


def test_parameter_defaults_build_the_default_config() -> None:
    values = {s.name: s.default for s in PARAMS}
    links = list(values["links"])  # type: ignore[arg-type]
    assert config_from_values(values, links, JOINT_NAMES[3:]) == ControllerConfig()


@pytest.mark.parametrize(("gains", "damping", "stiffness", "inertia"), [
    (CONTACT_CENTRING, (40.0,) * 6, (0.0,) * 6, 0.5),  # VI-A.1
    (CONTACT_TRACKING, (40.0, 40.0, 500.0, 40.0, 40.0, 40.0), (0.0,) * 6, 0.5),  # VI-A.2
    (WHOLE_BODY, (60.0,) * 6, (40.0,) * 6, 0.5),  # VI-A.3
    (WALTZ, (200.0,) * 6, (0.0,) * 6, 0.1),  # VI-B
])
def test_paper_admittance_sets(gains: AdmittanceGains, damping: tuple[float, ...],
                               stiffness: tuple[float, ...], inertia: float) -> None:
    assert gains.inertia == (inertia,) * 6
    assert gains.damping == damping
    assert gains.stiffness == stiffness


def test_dance_ranges_default_half_width_is_the_papers() -> None:
    (r,) = dance_ranges(["j"], [1.0])
    assert (r.lower, r.upper) == pytest.approx((0.9, 1.1))
