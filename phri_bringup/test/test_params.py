"""Parameter files: the paper's values, declared keys, values the nodes accept, documented."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from phri_bringup.graph import parameter_files as params
from phri_bringup.graph.nodes import CONTROLLER, ESTIMATION, SCENARIO_FILES, config_file

DOC = Path(__file__).resolve().parents[2] / "docs" / "bringup.md"
STEMS = [*SCENARIO_FILES.values(), "real"]


@pytest.mark.parametrize("stem", STEMS)
def test_file_keys_are_declared_and_values_accepted(stem: str) -> None:
    sections = params.load(config_file(stem))
    assert params.validate(sections) == []
    assert CONTROLLER in sections and ESTIMATION in sections


def test_files_match_the_paper_values_of_the_scenarios() -> None:
    assert params.check_files() == []


def test_paper_values_in_the_files() -> None:
    """Design §6 and Table II, stated independently of phri_sim.scenarios.catalogue."""
    table_ii = {"velocity_limit": 0.15, "k_eta": 200.0, "b": 4.0, "k_p": 5.0, "psi_thr": 1e-4,
                "epsilon": 0.1, "horizon": 0.15, "rate_hz": 100.0}
    expected = {  # (Λ, D, K) diagonals of every link
        "centring": ([0.5] * 6, [40.0] * 6, [0.0] * 6),
        "sliding": ([0.5] * 6, [40.0, 40.0, 500.0, 40.0, 40.0, 40.0], [0.0] * 6),
        "wholebody": ([0.5] * 6, [60.0] * 6, [40.0] * 6),
        "waltz_paper": ([0.1] * 6, [200.0] * 6, [0.0] * 6),
    }
    for stem, (inertia, damping, stiffness) in expected.items():
        ctl = params.load(config_file(stem))[CONTROLLER]
        for key, value in table_ii.items():
            assert ctl[key] == pytest.approx(value), (stem, key)
        for link in ("left_upper_arm_link", "left_forearm_link", "right_forearm_link"):
            assert ctl[f"{link}.inertia"] == inertia
            assert ctl[f"{link}.damping"] == damping
            assert ctl[f"{link}.stiffness"] == stiffness
        est = params.load(config_file(stem))[ESTIMATION]
        assert est["torque_limit"][1] == 1.2 and math.isinf(est["torque_limit"][0])
    waltz = params.load(config_file("waltz_paper"))[CONTROLLER]
    assert waltz["q_dance_enabled"] is True and waltz["q_dance_range"] == 0.1
    assert waltz["left_forearm_link.priority_lock"] == 1.0
    assert waltz["left_forearm_link.desired_force"] == [0.0, -10.0, 0.0]
    assert "lead_moment" not in waltz


def test_default_waltz_deviates_from_the_paper_only_where_documented() -> None:
    """The default waltz set (config/waltz.yaml) differs from the paper's (waltz_paper.yaml) in
    exactly the keys docs/wholebody_controller.md's "Following a turning partner" lists."""
    paper = params.load(config_file("waltz_paper"))[CONTROLLER]
    ours = params.load(config_file("waltz"))[CONTROLLER]
    changed = {k for k in set(paper) | set(ours) if paper.get(k) != ours.get(k)}
    links = ("left_upper_arm_link", "left_forearm_link", "right_forearm_link")
    # acceleration_limits: the default waltz commands within the robot's rated accelerations,
    # the paper's set leaves them free (docs/wholebody_controller.md, Parameters).
    assert changed == {"k_eta", "q_dance_range", "lead_moment", "acceleration_limits",
                       "turn_force_limit",
                       *(f"{link}.{g}" for link in links for g in ("inertia", "damping"))}
    doc = (Path(__file__).resolve().parents[2] / "docs" / "wholebody_controller.md").read_text(
        encoding="utf-8")
    section = doc.split("## Following a turning partner", 1)[1].split("\n## ", 1)[0]
    for key in ("k_eta", "q_dance_range", "lead_moment", "acceleration_limits",
                "turn_force_limit", "inertia", "damping"):
        assert f"`{key}`" in section, key
    assert params.load(config_file("sliding"))[CONTROLLER]["region_margin"] == 0.01


def test_validate_refuses_unknown_keys_and_bad_values() -> None:
    problems = params.validate({
        CONTROLLER: {"k_eta": -1.0, "no_such_parameter": 1, "q_dance_enabled": 1.0,
                     "left_forearm_link.damping": [40.0] * 5},
        ESTIMATION: {"torque_limit": [float("nan"), 1.0, 1.2]},
        "base_guard": {"anything": 1},  # not ours: not checked here
    })
    text = "\n".join(problems)
    assert len(problems) == 5, text
    assert "'k_eta'" in text and "[0, 100000]" in text
    assert "no_such_parameter" in text
    assert "q_dance_enabled" in text
    assert "left_forearm_link.damping" in text
    assert "torque_limit" in text and "NaN" in text


def test_load_refuses_a_file_without_ros_parameters(tmp_path: Path) -> None:
    bad = tmp_path / "bad.yaml"
    bad.write_text("wholebody_controller: {k_eta: 1.0}\n", encoding="utf-8")
    with pytest.raises(ValueError, match="ros__parameters"):
        params.load(bad)


def test_every_parameter_of_the_files_is_documented() -> None:
    doc = DOC.read_text(encoding="utf-8")
    for stem in STEMS:
        assert f"config/{stem}.yaml" in doc
        for values in params.load(config_file(stem)).values():
            for key in values:
                name = key.split(".", 1)[1] if key.startswith(("left_", "right_")) else key
                assert f"`{name}`" in doc or f"`{key}`" in doc, (stem, key)
