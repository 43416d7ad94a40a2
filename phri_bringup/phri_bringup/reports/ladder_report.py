"""The tempo ladder's table (``phri ladder``): one row per rung and plant, the robot beside the
motionless baseline, every number against its bar.

:func:`ladder_lines` formats :func:`phri_sim.studies.ladder.run_ladder`'s result as a markdown
table: per rung and plant a row for the robot and one for the motionless robot; a value that
misses its bar carries ``✗`` (the motionless robot's row is the same run under every plant: zero
commands are executed alike); ``n/a``: the bar does not apply (no turn of the partner for the
turning lag, no stop for the time to rest); ``-``: not measured. The last column lists the bars
the robot missed.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from phri_sim.ros.run_options import MOTIONLESS

Cell = Callable[[dict[str, Any]], tuple[str, str | None]]
"""A column: (text, the name of the check it shows in ``pass``, if any) of one run."""


def _fmt(value: Any, scale: float = 1.0, digits: int = 1) -> str:
    if value is None:
        return "-"
    return f"{value * scale:.{digits}f}"


def _band(run: dict[str, Any]) -> tuple[str, str | None]:
    return _fmt(run["following"]["band_share"], 100.0, 0), "band_share"


def _held(run: dict[str, Any]) -> tuple[str, str | None]:
    return _fmt(run["following"]["held_share"], 100.0, 0), "held_share"


def _drift(run: dict[str, Any]) -> tuple[str, str | None]:
    f = run["following"]
    return (f"{_fmt(f['position_drift_rms'], 100.0)} / {_fmt(f['position_drift_max'], 100.0)}",
            "position_drift")


def _heading(run: dict[str, Any]) -> tuple[str, str | None]:
    return _fmt(run["following"]["heading_drift_max_deg"]), "heading_drift"


def _peak(run: dict[str, Any]) -> tuple[str, str | None]:
    person = run["following"].get("peak_force", {}).get("person", {})
    return _fmt(max(person.values(), default=None)), "partner_force"


def _turn_lag(run: dict[str, Any]) -> tuple[str, str | None]:
    return _fmt(run["following"].get("turning_lag"), digits=2), "turning_lag"


def _fluct(run: dict[str, Any]) -> tuple[str, str | None]:
    return _fmt(run["following"].get("force_fluctuation", {}).get("rms"), digits=2), \
        "force_fluctuation"


def _accel(run: dict[str, Any]) -> tuple[str, str | None]:
    commanded = run["following"].get("base_acceleration", {}).get("commanded")
    if commanded is None:
        return "-", "command_acceleration"
    return "/".join(_fmt(a, digits=2) for a in commanded["p99"]), "command_acceleration"


def _rest(run: dict[str, Any]) -> tuple[str, str | None]:
    rest = run["following"].get("rest")
    if rest is None:
        return "-", "rest_time"
    if not rest["stops"]:
        return "no stop", "rest_time"
    value = rest["time_to_rest_max"]
    return ("never" if value is None else _fmt(value, digits=2)), "rest_time"


def _loss(run: dict[str, Any]) -> tuple[str, str | None]:
    losses = run["following"]["contact_losses"]
    return f"{losses['count']} / {_fmt(losses['time_to_regain_max'], digits=2)}", "contact_loss"


def _iso(run: dict[str, Any]) -> tuple[str, str | None]:
    return ("ok" if run["iso15066_ok"] else "over"), "iso15066"


COLUMNS: tuple[tuple[str, Cell], ...] = (
    ("band 2–25 N [%]", _band), ("held [%]", _held), ("drift RMS / max [cm]", _drift),
    ("heading max [°]", _heading), ("peak on partner [N]", _peak),
    ("turning lag [s]", _turn_lag), ("waist > 1 Hz RMS [N]", _fluct),
    ("cmd base acc p99 x/y/ψ", _accel), ("rest after stop [s]", _rest),
    ("losses / longest [s]", _loss), ("ISO/TS 15066", _iso),
)
"""The table's value columns: (header, cell)."""


def _mark(run: dict[str, Any], text: str, check: str | None) -> str:
    verdicts = run["pass"]
    keys = [k for k in verdicts if check is not None and k.startswith(check)]
    if any(verdicts[k] is False for k in keys):
        return text + " ✗"
    if keys and all(verdicts[k] is None for k in keys):
        return "n/a" if text in ("-", "no stop") else text
    return text


def _row(label: str, plant: str, run: dict[str, Any]) -> str:
    cells = [_mark(run, *cell(run)) for _, cell in COLUMNS]
    missed = [k for k, v in run["pass"].items() if v is False and k != "all"]
    verdict = "yes" if run["pass"]["all"] else "NO: " + ", ".join(missed)
    return f"| {label} | {plant} | " + " | ".join(cells) + f" | {verdict} |"


def ladder_lines(result: dict[str, Any]) -> list[str]:
    """The markdown table of a ladder result (module docstring) and a line of timing."""
    header = ["rung", "plant", *(h for h, _ in COLUMNS), "within the bars"]
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    runs = result["runs"]
    robots = [r for r in runs if r["controller"] != MOTIONLESS]
    still = {r["rung"]: r for r in runs if r["controller"] == MOTIONLESS}
    for run in robots:
        label = f"{run['rung']} ({run['duration']:.0f} s, {run['bars_name']} bars)"
        lines.append(_row(label, run["plant"], run))
        other = still.get(run["rung"])
        if other is not None:
            lines.append(_row("  motionless", "any", other))
    cpu = sum(r.get("cpu_time") or 0.0 for r in runs)
    lines.append(f"{len(runs)} runs, wall {result['wall_time']:.0f} s with {result['jobs']} "
                 f"job(s), CPU {cpu:.0f} s (the runs' own)")
    return lines
