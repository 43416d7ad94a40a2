"""Per-control-period series of a scenario run for the paper's figures and checks (no plotting).

:func:`record_scenario` runs a scenario through the real nodes in lock-step
(:class:`~phri_sim.ros.runner.ScenarioRun`) and keeps, every control period, what the panels of
Figs 6–8 show: per skin link the true force and centre (physics), the estimated force, torque,
centre and region (contact_estimation), the controller's weight ψ, phase and track force
k_η ⁰μ_η; the base velocity commanded and measured and the arm joint velocities. Nothing is
recorded to disk, so it is cheap enough for tests; :mod:`phri_sim.studies.paper_checks` reduces it
to the numbers of ``docs/paper_vs_phri.md``.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from phri_description.description import SKIN_LINKS
from phri_sim.scenarios.catalogue import scenario_named, with_parameter_set

FloatArray = NDArray[np.float64]

LINK_FIELDS = ("true_force", "true_centre", "force", "torque", "centre", "in_contact",
               "region_min", "region_max", "psi", "phase", "track_force", "track_force_link")
"""Per-link series (N × k arrays; vectors in the link frame except the world-frame track
force): true normal force [N] and centre [m], estimated ‖f_η‖ [N], τ_η [N·m], p_η [m], in contact
(0/1), Ω_i corners [m], ψ [-], phase (Fig. 5, 0–3), k_η ⁰μ_η [N] (world) and the same in the
link frame [N]."""


@dataclass
class FigureSeries:
    """Samples of one run, one per control period (module docstring)."""

    scenario: str
    parameter_set: str
    t: FloatArray
    links: dict[str, dict[str, FloatArray]] = field(default_factory=dict)
    command: FloatArray = field(default_factory=lambda: np.zeros((0, 15)))
    """The command the servos follow: base body twist (v_x, v_y, ω_z) [m/s, rad/s], then the
    arm joint velocities, left then right arm [rad/s]."""
    base_velocity: FloatArray = field(default_factory=lambda: np.zeros((0, 3)))
    """Measured base twist (body frame v_x, v_y, ω_z) [m/s, rad/s]."""
    arm_velocity: FloatArray = field(default_factory=lambda: np.zeros((0, 12)))
    """Measured arm joint velocities, left then right arm [rad/s]."""
    parameters: dict[str, Any] = field(default_factory=dict)


class _Collector:
    """Rows appended every control period."""

    def __init__(self) -> None:
        self.t: list[float] = []
        self.rows: dict[str, dict[str, list[Any]]] = {
            link: {k: [] for k in LINK_FIELDS} for link in SKIN_LINKS}
        self.cmd: list[FloatArray] = []
        self.base: list[FloatArray] = []
        self.arm: list[FloatArray] = []
        self.tasks: dict[str, Any] = {}

    def sample(self, sim: Any, command: FloatArray, estimates: Mapping[str, Any]) -> None:
        self.t.append(sim.time)
        truth = sim.ground_truth()
        for link in SKIN_LINKS:
            row, gt, task = self.rows[link], truth[link], self.tasks.get(link)
            est: Any = estimates.get(link)
            row["true_force"].append(gt.normal_force if gt.in_contact else 0.0)
            row["true_centre"].append(np.array(gt.center_link) if gt.in_contact
                                      else np.full(3, np.nan))
            touched = est is not None and bool(est.in_contact)
            row["in_contact"].append(float(touched))
            row["force"].append(float(np.linalg.norm(est.force)) if touched else 0.0)
            row["torque"].append(np.array(est.torque) if touched else np.zeros(3))
            nan3 = np.full(3, np.nan)
            row["centre"].append(np.array(est.center) if touched else nan3)
            row["region_min"].append(np.array(est.region_min) if touched else nan3)
            row["region_max"].append(np.array(est.region_max) if touched else nan3)
            row["psi"].append(task.psi if task is not None else 0.0)
            row["phase"].append(float(task.phase) if task is not None else 0.0)
            mu = np.array(task.track_force) if task is not None else np.zeros(3)
            row["track_force"].append(mu)
            row["track_force_link"].append(sim.link_pose(link)[0].T @ mu)
        self.cmd.append(np.array(command, dtype=float))
        self.base.append(np.array(sim.base_twist()))
        self.arm.append(np.array(sim.qd[3:]))

    def series(self, scenario: str, parameter_set: str, params: dict[str, Any]) -> FigureSeries:
        links = {link: {k: np.array(v, dtype=float) for k, v in row.items()}
                 for link, row in self.rows.items()}
        return FigureSeries(scenario, parameter_set, np.array(self.t), links,
                            np.array(self.cmd), np.array(self.base), np.array(self.arm), params)


def record_scenario(name: str, *, context: Any, duration: float | None = None, seed: int = 0,
                    parameters: str = "phri") -> FigureSeries:
    """Run the catalogue's scenario ``name`` with its parameter set ``parameters``
    (:func:`~phri_sim.scenarios.catalogue.with_parameter_set`) for ``duration`` [s] (None: its
    length) and return its series."""
    from phri_sim.ros.run_options import RunOptions
    from phri_sim.ros.runner import ScenarioRun

    collector = _Collector()
    scenario = with_parameter_set(scenario_named(name), parameters)
    params = scenario.controller_parameters
    run = ScenarioRun(scenario, RunOptions(duration=duration, seed=seed), context=context)
    try:
        controller = run.controller.controller
        step = controller.step

        def capture(q: FloatArray, contacts: Mapping[str, Any]) -> Any:
            result = step(q, contacts)
            collector.tasks = {task.link: task for task in result.tasks}
            return result

        controller.step = capture
        metrics_sample = run.metrics.sample

        def sample(sim: Any, command: FloatArray, estimates: Mapping[str, Any]) -> None:
            metrics_sample(sim, command, estimates)
            collector.sample(sim, command, estimates)

        run.metrics.sample = sample
        run.run()
    finally:
        run.close()
    return collector.series(name, parameters, params)
