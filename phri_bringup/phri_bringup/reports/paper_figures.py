"""The paper's Figs 6–8, panel by panel with the paper's letters, and ``phri paper-report``.

:func:`figure_6`, :func:`figure_7` and :func:`figure_8` draw one composed page per figure from a
run's :class:`~phri_sim.studies.figure_series.FigureSeries`, laid out like the paper (two columns,
panels in letter order), each panel titled with the paper's caption; what the simulator knows
besides (true force, true contact centre) is drawn dashed. :func:`paper_report` runs the three
scenarios (centring and sliding again with the paper-literal Ω_d), writes the three pages and the
``paper_vs_phri.md`` page of :mod:`phri_sim.studies.paper_checks`.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from phri_common import paper
from phri_sim.studies.figure_series import FigureSeries

LIMIT = paper.VELOCITY_LIMIT
AXES = ("x", "y", "z")
LINK_NAMES = {"left_upper_arm_link": "link 1 (left upper arm)",
              "left_forearm_link": "link 2 (left forearm)",
              "right_forearm_link": "link 3 (right forearm)"}
"""Fig. 8's link numbering (paper: "the three links enveloped with the electronic skin")."""


def _page(rows: int, title: str) -> tuple[Any, Any]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(rows, 2, figsize=(12, 2.6 * rows + 0.8), sharex=True,
                             squeeze=False)
    fig.suptitle(title)
    return fig, axes


def _save(fig: Any, path: Path) -> Path:
    import matplotlib.pyplot as plt

    for ax in fig.axes:
        ax.grid(True, linewidth=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path


def _force(ax: Any, s: FigureSeries, link: str, title: str) -> None:
    ax.plot(s.t, s.links[link]["force"], label="estimated ‖f_η‖ (9a)")
    ax.plot(s.t, s.links[link]["true_force"], "--", label="true (simulator)")
    ax.set_title(title, fontsize=9)
    ax.set_ylabel("[N]")
    ax.legend(fontsize=7, loc="upper right")


def _psi(ax: Any, s: FigureSeries, links: list[str], title: str) -> None:
    for link in links:
        ax.semilogy(s.t, np.maximum(s.links[link]["psi"], 1e-6), label=LINK_NAMES[link])
    ax.axhline(paper.PSI_THR, color="k", linestyle=":", linewidth=0.8, label="ψ_thr")
    ax.set_title(title, fontsize=9)
    ax.set_ylabel("ψ [-]")
    ax.legend(fontsize=7, loc="upper right")


def _joints(ax: Any, s: FigureSeries, arm: str, title: str) -> None:
    first = 0 if arm == "left" else 6
    names = ("shoulder pan", "shoulder lift", "elbow", "wrist 1", "wrist 2", "wrist 3")
    for k, name in enumerate(names):
        ax.plot(s.t, s.arm_velocity[:, first + k], label=name, linewidth=0.9)
    for bound in (-LIMIT, LIMIT):
        ax.axhline(bound, color="k", linestyle=":", linewidth=0.8)
    ax.set_title(title, fontsize=9)
    ax.set_ylabel("[rad/s]")
    ax.legend(fontsize=6, ncol=3, loc="upper right")


def _base(ax: Any, s: FigureSeries, title: str) -> None:
    for k, label in enumerate(("v_x [m/s]", "v_y [m/s]", "ω_z [rad/s]")):
        line = ax.plot(s.t, s.base_velocity[:, k], label=label)[0]
        ax.plot(s.t, s.command[:, k], ":", color=line.get_color(), linewidth=0.8)
    ax.set_title(title + " (dotted: commanded)", fontsize=9)
    ax.legend(fontsize=7, loc="upper right")


def _centre(ax: Any, s: FigureSeries, link: str, title: str, axes: tuple[int, ...]) -> None:
    for k in axes:
        line = ax.plot(s.t, s.links[link]["centre"][:, k], label=f"p_η,{AXES[k]}")[0]
        ax.plot(s.t, s.links[link]["true_centre"][:, k], "--", color=line.get_color(),
                linewidth=0.8, label=f"true {AXES[k]}")
    ax.set_title(title + " (link frame; dashed: true)", fontsize=9)
    ax.set_ylabel("[m]")
    ax.legend(fontsize=7, ncol=2, loc="upper right")


def _mark(axes: Any, times: list[tuple[float, str]]) -> None:
    """Number the scenario's events over time, as the paper does."""
    for ax in np.ravel(axes):
        for t, label in times:
            ax.axvline(t, color="0.6", linewidth=0.6)
            ax.text(t, 1.0, label, transform=ax.get_xaxis_transform(), fontsize=9,
                    va="bottom", ha="center")


def figure_6(s: FigureSeries, out: Path) -> Path:
    """Fig. 6, contact centring: (a) resultant force, (b) estimated torque, (c) centre position,
    (d) weight, (e) right arm joint velocity, (f) base velocity."""
    from phri_sim.scenarios.catalogue import CENTRING_EVEN, CENTRING_TWO_SIDED

    link = "right_forearm_link"
    fig, ax = _page(3, "Fig. 6 — contact centring (scenario centring)")
    _force(ax[0, 0], s, link, "(a) Resultant force")
    for k in range(3):
        ax[0, 1].plot(s.t, s.links[link]["torque"][:, k], label=f"τ_{AXES[k]}")
    limit = paper.TORQUE_LIMIT[1]
    for bound in (-limit, limit):
        ax[0, 1].axhline(bound, color="k", linestyle=":", linewidth=0.8)
    ax[0, 1].set_title(f"(b) Estimated torque (link frame; limit |τ_y| ≤ {limit:g})", fontsize=9)
    ax[0, 1].set_ylabel("[N·m]")
    ax[0, 1].legend(fontsize=7, loc="upper right")
    _centre(ax[1, 0], s, link, "(c) Center position", (0, 1, 2))
    _psi(ax[1, 1], s, [link], "(d) Weight for contact center")
    _joints(ax[2, 0], s, "right", "(e) Right arm joint velocity")
    _base(ax[2, 1], s, "(f) Base velocity")
    _mark(ax, [(CENTRING_EVEN[0], "①"), (CENTRING_TWO_SIDED[0], "②")])
    for a in ax[-1]:
        a.set_xlabel("time [s]")
    return _save(fig, out / "fig6_contact_centring.png")


def figure_7(s: FigureSeries, out: Path) -> Path:
    """Fig. 7, contact-change tracking: (a) track force, (b) weight, (c) left arm joint velocity,
    (d) base velocity; plus the contact centre against the true one (what (a) reacts to)."""
    from phri_sim.scenarios.catalogue import SLIDE_MOVES

    link = "left_forearm_link"
    fig, ax = _page(3, "Fig. 7 — contact-change tracking (scenario sliding)")
    for k in range(3):
        ax[0, 0].plot(s.t, s.links[link]["track_force"][:, k], label=f"k_η μ_{AXES[k]}")
    ax[0, 0].set_title("(a) Track force k_η ⁰μ_η (world frame)", fontsize=9)
    ax[0, 0].set_ylabel("[N]")
    ax[0, 0].legend(fontsize=7, loc="upper right")
    _centre(ax[0, 1], s, link, "(a, detail) contact centre and region Ω_i along the link", (0,))
    ax[0, 1].fill_between(s.t, s.links[link]["region_min"][:, 0],
                          s.links[link]["region_max"][:, 0], alpha=0.2, label="Ω_i (x)")
    _psi(ax[1, 0], s, [link], "(b) Weight for contact center")
    _joints(ax[1, 1], s, "left", "(c) Left arm joint velocity")
    _base(ax[2, 0], s, "(d) Base velocity")
    _force(ax[2, 1], s, link, "(normal force of the sliding hand)")
    _mark(ax, [(start, "→") for start, _, _ in SLIDE_MOVES])
    for a in ax[-1]:
        a.set_xlabel("time [s]")
    return _save(fig, out / "fig7_contact_tracking.png")


def figure_8(s: FigureSeries, out: Path) -> Path:
    """Fig. 8, whole-body pHRI: (a–c) resultant force of links 1–3, (d) weights, (e) base
    velocity, (f) right and (g) left arm joint velocity."""
    links = list(LINK_NAMES)
    fig, ax = _page(4, "Fig. 8 — whole-body pHRI (scenario whole_body)")
    for k, (letter, link) in enumerate(zip("abc", links, strict=True)):
        _force(ax.flat[k], s, link, f"({letter}) Resultant force of {LINK_NAMES[link]}")
    _psi(ax.flat[3], s, links, "(d) Weight for contact center")
    _base(ax.flat[4], s, "(e) Base velocity")
    _joints(ax.flat[5], s, "right", "(f) Right arm joint velocity")
    _joints(ax.flat[6], s, "left", "(g) Left arm joint velocity")
    ax.flat[7].axis("off")
    ax.flat[5].tick_params(labelbottom=True)
    for a in (ax.flat[5], ax.flat[6]):
        a.set_xlabel("time [s]")
    return _save(fig, out / "fig8_wholebody.png")


PAGES = {"centring": figure_6, "sliding": figure_7, "whole_body": figure_8}
"""The paper's figure of each basic scenario."""


def figure_page(scenario: str, s: FigureSeries, out: Path) -> Path:
    """The paper's figure page of ``scenario`` (:data:`PAGES`) into ``out``."""
    return PAGES[scenario](s, out)


def _at(series: Any, t: np.ndarray, width: int, fill: float = 0.0) -> np.ndarray:
    """``series`` (times, values) sampled at ``t`` by the latest sample at or before each time
    (``fill`` before the first)."""
    out = np.full((len(t), width), fill)
    if len(series.t):
        k = np.searchsorted(series.t, t + 1e-9, side="right") - 1
        ok = k >= 0
        out[ok] = series.v[k[ok]]
    return out


def series_from_run(data: Any, scenario: str) -> FigureSeries:
    """A recording read by :func:`phri_bringup.reports.plots.read_run` as a
    :class:`~phri_sim.studies.figure_series.FigureSeries` on the controller's state times (the arm
    commands, not recorded, are zero; the true force is the norm of the true total force)."""
    links = list(data.psi)
    base = next((data.psi[k] for k in links if len(data.psi[k].t)), None)
    t = base.t if base is not None else np.zeros(0)
    nan = float("nan")
    out: dict[str, dict[str, np.ndarray]] = {}
    for link in links:
        touched = _at(data.in_contact[link], t, 1)[:, 0] > 0
        true_force = _at(data.true_force[link], t, 3)
        true_centre = _at(data.true_centre[link], t, 3, nan)
        force = np.linalg.norm(_at(data.force[link], t, 3), axis=1)
        region = _at(data.region[link], t, 6, nan)
        out[link] = {
            "true_force": np.linalg.norm(true_force, axis=1),
            "true_centre": np.where((np.linalg.norm(true_force, axis=1) > 0)[:, None],
                                    true_centre, nan),
            "force": np.where(touched, force, 0.0),
            "torque": np.where(touched[:, None], _at(data.torque[link], t, 3), 0.0),
            "centre": np.where(touched[:, None], _at(data.centre[link], t, 3, nan), nan),
            "in_contact": touched.astype(float),
            "region_min": np.where(touched[:, None], region[:, :3], nan),
            "region_max": np.where(touched[:, None], region[:, 3:], nan),
            "psi": _at(data.psi[link], t, 1)[:, 0],
            "track_force": _at(data.track_force[link], t, 3),
        }
    command = np.zeros((len(t), 15))
    command[:, :3] = _at(data.cmd_vel, t, 3)
    return FigureSeries(scenario, "recording", t, out, command, _at(data.odom, t, 6)[:, 3:],
                        _at(data.joint_velocity, t, 12))


Recorder = Callable[..., FigureSeries]


def paper_report(out: Path, *, seed: int = 0, context: Any,
                 record: Recorder | None = None) -> tuple[list[Path], str, list[Any]]:
    """Run the three scenarios (``record``:
    :func:`~phri_sim.studies.figure_series.record_scenario`), draw Figs 6–8 into ``out`` and return
    (the files, the markdown page, the checks)."""
    from phri_sim.studies.figure_series import record_scenario
    from phri_sim.studies.paper_checks import (
        centring_checks,
        render,
        sliding_checks,
        whole_body_checks,
    )

    rec = record or record_scenario
    out.mkdir(parents=True, exist_ok=True)
    centring = rec("centring", context=context, seed=seed)
    centring_literal = rec("centring", context=context, seed=seed, parameters="literal")
    sliding = rec("sliding", context=context, seed=seed)
    literal = rec("sliding", context=context, seed=seed, parameters="literal")
    whole = rec("whole_body", context=context, seed=seed)
    files = [figure_6(centring, out), figure_7(sliding, out), figure_8(whole, out)]
    checks = [*centring_checks(centring, centring_literal), *sliding_checks(sliding, literal),
              *whole_body_checks(whole)]
    return files, render(checks, seed), checks
