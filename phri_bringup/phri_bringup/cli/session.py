"""One simulated session: the graph's in-process nodes, lock-step, with the parameter files.

Wraps :class:`phri_sim.ros.runner.ScenarioRun` so that

* the nodes get the sections of the same ``config/<scenario>.yaml`` the launch file passes
  (the runner's own lock-step values, :data:`phri_bringup.graph.nodes.LOCKSTEP_OVERRIDES`,
  excepted);
* an :class:`~phri_bringup.observer.node.ObserverNode` joins the executor (recording, live view);
* shutdown is ordered: the controller goes first (its ``destroy_node`` publishes zero velocity),
  the executor spins until the observer and the simulator have received that zero command, then
  everything else is destroyed and the context shut down — on a normal end, an error, or a stop
  request (Ctrl-C / SIGTERM via :class:`StopFlag`).
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

import rclpy
from rclpy.context import Context
from rclpy.signals import SignalHandlerOptions

import phri_bringup.graph.parameter_files as param_files
from phri_bringup.graph.nodes import (
    BRIDGE,
    CONTROLLER,
    ESTIMATION,
    canonical_scenario,
    config_file,
    robot_description_urdf,
)
from phri_bringup.graph.nodes import scenario_file as scenario_file_stem
from phri_bringup.observer.node import ObserverNode, Sink

if TYPE_CHECKING:
    from phri_sim.ros.run_options import RunOptions
    from phri_sim.scenarios.catalogue import Scenario

ZERO_WAIT_S = 3.0
"""Wall time [s] the shutdown waits for the final zero command to be received."""


class Interrupted(RuntimeError):
    """The session was asked to stop (Ctrl-C / SIGTERM) before its end."""


class StopFlag:
    """Set from a signal handler; checked by the session between control periods."""

    def __init__(self) -> None:
        self.requested = False

    def set(self, *_: Any) -> None:
        self.requested = True


@dataclasses.dataclass
class SessionResult:
    """What a session produced."""

    metrics: dict[str, Any]
    zero_at_exit: bool
    interrupted: bool
    message_counts: dict[str, int]


def load_sections(scenario: str, params_file: str | Path | None = None
                  ) -> dict[str, dict[str, Any]]:
    """Parameter sections of a scenario's file (or ``params_file``), validated.

    Raises:
        ValueError: a key is not a declared parameter or a value is refused (all listed).
    """
    path = Path(params_file) if params_file else config_file(scenario_file_stem(scenario))
    sections = param_files.load(path)
    problems = param_files.validate(sections)
    if problems:
        raise ValueError(f"{path}: " + "; ".join(problems))
    return sections


def session_scenario(scenario: str, params_file: str | Path | None = None) -> Scenario:
    """The catalogue's ``scenario`` (any accepted spelling) with the controller and estimation
    sections of its parameter file (or ``params_file``): the values the launch file gives the
    nodes, as a scenario value for the runner.

    Raises:
        ValueError: the file is refused (:func:`load_sections`) or is for another scenario.
    """
    from phri_sim.scenarios.catalogue import scenario_named

    name = canonical_scenario(scenario)
    sections = load_sections(name, params_file)
    bridge_scenario = sections.get(BRIDGE, {}).get("scenario", name)
    if bridge_scenario != name:
        raise ValueError(f"parameter file is for scenario {bridge_scenario!r}, not {name!r}")
    base = scenario_named(name)
    return dataclasses.replace(
        base,
        controller_parameters=dict(sections.get(CONTROLLER, base.controller_parameters)),
        estimation_parameters=dict(sections.get(ESTIMATION, base.estimation_parameters)),
    )


def run_session(
    scenario: str,
    options: RunOptions | None = None,
    *,
    sinks: list[Sink] | None = None,
    params_file: str | Path | None = None,
    pace: float | None = None,
    progress: Callable[[float, float], None] | None = None,
    stop: StopFlag | None = None,
    context: Context | None = None,
    inspect: Callable[[Any], None] | None = None,
    vary: Callable[[Scenario], Scenario] | None = None,
) -> SessionResult:
    """Run ``scenario`` (any accepted spelling, :func:`session_scenario`) lock-step through the
    real nodes.

    Args:
        options: how it is simulated (:class:`phri_sim.ros.run_options.RunOptions`: length,
            seed, fidelity, skin driver, sensor path, sensor fault; None: the defaults).
        sinks: receive every documented topic (closed at the end, also on errors).
        params_file: parameter file instead of ``config/<scenario>.yaml``.
        pace: run at most this many times faster than the wall clock (live viewing).
        progress: called with (sim time [s], duration [s]) once per simulated second.
        stop: checked once per simulated second; when set, the run ends early (zero command,
            clean shutdown) and ``interrupted`` is True.
        context: an initialised rclpy context to use (tests); else one is made and shut down.
        inspect: called with the :class:`~phri_sim.ros.runner.ScenarioRun` before it runs (tests).
        vary: turns the scenario (with the file's parameters) into the one run: another
            partner (:func:`phri_sim.scenarios.catalogue.with_partner`) or an unscripted lead.
    """
    from phri_sim.ros.runner import ScenarioRun

    values = session_scenario(scenario, params_file)
    if vary is not None:
        values = vary(values)
    own = context is None
    if own:
        context = Context()
        rclpy.init(context=context, signal_handler_options=SignalHandlerOptions.NO)
    assert context is not None
    hooks = _Hooks(sinks or [], pace, progress, stop)
    run = None
    metrics: dict[str, Any] = {}
    interrupted = zero = False
    try:
        run = ScenarioRun(values, options, context=context, recorder=hooks.make_observer,
                          progress=hooks.on_progress)
        if inspect is not None:
            inspect(run)
        try:
            metrics = run.run()
        except Interrupted:
            interrupted = True
    finally:
        if run is not None:
            zero = _shutdown(run, hooks.observer)
        for sink in hooks.sinks:
            sink.close()
        if own:
            context.try_shutdown()
    return SessionResult(metrics, zero, interrupted,
                         dict(hooks.observer.message_counts) if hooks.observer else {})


class _Hooks:
    """What a session adds to its run: the observer node (feeding ``sinks``, paced to ``pace``
    × real time) and the progress callback, which ends the run on a stop request."""

    def __init__(self, sinks: list[Sink], pace: float | None,
                 progress: Callable[[float, float], None] | None, stop: StopFlag | None) -> None:
        self.sinks, self.pace, self.progress, self.stop = sinks, pace, progress, stop
        self.observer: ObserverNode | None = None

    def make_observer(self, ctx: Context) -> ObserverNode:
        """The run's observer node (the runner's ``recorder`` factory)."""
        self.observer = ObserverNode(ctx, self.sinks, pace=self.pace,
                                     robot_description=robot_description_urdf())
        return self.observer

    def on_progress(self, t: float, total: float) -> None:
        """Once per simulated second (sim time ``t`` of ``total`` [s])."""
        if self.stop is not None and self.stop.requested:
            raise Interrupted(f"stopped at sim time {t:.1f} s")
        if self.progress is not None:
            self.progress(t, total)


def _shutdown(run: Any, observer: ObserverNode | None) -> bool:
    """Controller first (zero command), wait until it arrived, then the rest; True if the
    observer's last commands were zero."""
    executor = run.executor
    controller = run.controller
    executor.remove_node(controller)
    controller.destroy_node()  # publishes zero velocity on /cmd_vel and both arms
    zero = False
    deadline = time.monotonic() + ZERO_WAIT_S
    while observer is not None and time.monotonic() < deadline:
        executor.spin_once(timeout_sec=0.05)
        if observer.last_command_is_zero():
            zero = True
            break
    # Let the simulator take the zero command too (it would time out to zero anyway).
    for _ in range(5):
        executor.spin_once(timeout_sec=0.01)
    for node in (*run.extra, run.probe, run.estimation, run.bridge):
        executor.remove_node(node)
        node.destroy_node()
    executor.shutdown()
    return zero
