"""``phri ladder`` and ``phri sim``'s plant and partner options: the table against the bars, the
rungs the arguments name, the choices kept in step with the simulator, the docs; one small
ladder and one unscripted lead through the real nodes."""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from phri_bringup.cli.ladder import rung_specs
from phri_bringup.cli.main import LEAD_CHOICES, PLANT_CHOICES, _parser
from phri_bringup.reports.ladder_report import ladder_lines
from phri_sim.ros.run_options import MOTIONLESS
from phri_sim.studies.unscripted_leads import UNSCRIPTED_LEADS
from phri_sim.world.actuators import PLANTS

DOC = Path(__file__).resolve().parents[2] / "docs" / "bringup.md"


def test_the_cli_choices_are_the_simulators() -> None:
    assert tuple(PLANTS) == PLANT_CHOICES
    assert tuple(UNSCRIPTED_LEADS) == LEAD_CHOICES


def _run(rung: str, controller: str, passes: dict[str, bool | None], **following: Any
         ) -> dict[str, Any]:
    block = {"band_share": 0.5, "held_share": 0.9, "position_drift_rms": 0.02,
             "position_drift_max": 0.04, "heading_drift_max_deg": 3.0, "turning_lag": None,
             "contact_losses": {"count": 1, "time_to_regain_max": 0.2},
             "rest": {"stops": [], "time_to_rest_max": None}, **following}
    return {"rung": rung, "plant": "realistic", "duration": 30.0, "bars_name": "waltz",
            "controller": controller, "following": block, "iso15066_ok": True,
            "pass": {**passes, "all": all(v is not False for v in passes.values())},
            "cpu_time": 1.0}


def test_the_table_marks_missed_bars_and_the_bars_that_do_not_apply() -> None:
    robot = _run("x1", "wholebody_controller",
                 {"band_share": False, "turning_lag": None, "rest_time": None,
                  "position_drift_rms": True, "position_drift_max": True})
    still = _run("x1", MOTIONLESS, {"band_share": False})
    lines = ladder_lines({"runs": [robot, still], "wall_time": 12.0, "jobs": 2})
    header = [c.strip() for c in lines[0].split("|")[1:-1]]
    row = dict(zip(header, (c.strip() for c in lines[2].split("|")[1:-1]), strict=True))
    assert row["band 2–25 N [%]"] == "50 ✗"
    assert row["turning lag [s]"] == "n/a" and row["rest after stop [s]"] == "n/a"
    assert row["drift RMS / max [cm]"] == "2.0 / 4.0"
    assert row["within the bars"] == "NO: band_share"
    assert lines[3].startswith("|   motionless | any |")
    assert "2 runs, wall 12 s with 2 job(s)" in lines[-1]


def _ladder_args(**values: Any) -> argparse.Namespace:
    defaults = {"rungs": None, "seeds": "1,2,3", "full": False, "params": None}
    return argparse.Namespace(**{**defaults, **values})


def test_the_rungs_of_the_arguments() -> None:
    names = [s.name for s in rung_specs(_ladder_args())]
    assert names[:7] == ["x1", "x2", "x4", "tempo", "sway1", "sway2", "sway3"]
    assert len(names) == 7 + len(UNSCRIPTED_LEADS)
    picked = rung_specs(_ladder_args(rungs="x1.5, lead:box", full=True))
    assert [(s.name, s.full) for s in picked] == [("x1.5", True), ("lead:box", True)]
    with pytest.raises(ValueError, match="rung 'x0'"):
        rung_specs(_ladder_args(rungs="x0"))
    with pytest.raises(ValueError, match="--seeds"):
        rung_specs(_ladder_args(seeds="one"))
    with pytest.raises(ValueError, match="--params"):
        rung_specs(_ladder_args(params="no/such/file.yaml"))


def test_ladder_and_the_new_sim_options_are_documented() -> None:
    text = DOC.read_text(encoding="utf-8")
    sub = next(a for a in _parser()._actions if a.dest == "command")
    options = {o for name in ("ladder", "sim")
               for a in sub.choices[name]._actions  # type: ignore[index]
               for o in a.option_strings if o.startswith("--") and o != "--help"}
    assert "phri ladder" in text
    missing = [o for o in sorted(options) if f"`{o}" not in text and f" {o}" not in text
               and f"[{o}" not in text]
    assert not missing, f"options missing from docs/bringup.md: {missing}"


def test_a_partner_option_outside_the_waltz_is_a_one_line_error(tmp_path: Path) -> None:
    proc = subprocess.run([sys.executable, "-m", "phri_bringup.cli.main", "sim", "--scenario",
                           "centring", "--tempo-scale", "2", "--no-record",
                           "--out", str(tmp_path / "run")], capture_output=True, text=True,
                          timeout=120)
    assert proc.returncode == 2
    assert "waltz only" in proc.stderr
    assert not (tmp_path / "run").exists()


@pytest.mark.ros
def test_a_small_ladder_on_both_plants(tmp_path: Path) -> None:
    """The fast couple turn on both plants beside one motionless run: a row per plant and the
    motionless row under each; the two plants' robots differ, the JSON holds every run."""
    out = tmp_path / "ladder"
    proc = subprocess.run([sys.executable, "-m", "phri_bringup.cli.main", "ladder", "--rungs",
                           "lead:pivot_fast", "--plant", "both", "--jobs", "2", "--out",
                           str(out)], capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-3000:]
    result = json.loads((out / "ladder.json").read_text())
    runs = {(r["plant"], r["controller"]): r for r in result["runs"]}
    assert len(result["runs"]) == 3
    still = runs[("realistic", MOTIONLESS)]["following"]
    assert still["base_acceleration"]["commanded"]["max"] == [0.0, 0.0, 0.0]
    real = runs[("realistic", "wholebody_controller")]["following"]
    ideal = runs[("ideal", "wholebody_controller")]["following"]
    assert real["travel"]["robot"] != ideal["travel"]["robot"]
    table = (out / "ladder.md").read_text()
    assert table.count("| lead:pivot_fast") == 2 and table.count("|   motionless") == 2


@pytest.mark.ros
def test_phri_sim_runs_an_unscripted_lead(tmp_path: Path) -> None:
    out = tmp_path / "lead"
    proc = subprocess.run([sys.executable, "-m", "phri_bringup.cli.main", "sim", "--lead",
                           "spin_left", "--duration", "3", "--no-record", "--no-baseline",
                           "--out", str(out)], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-3000:]
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics["partner"] == {"lead": "spin_left"} and metrics["plant"] == "realistic"
    assert "turning_lag" in metrics["following"]
