"""In-process scenario runner: bridge + contact estimation + controller on one executor, lock-step.

:class:`ScenarioRun` takes a :class:`~phri_sim.scenarios.catalogue.Scenario` and its
:class:`~phri_sim.ros.run_options.RunOptions` (both values: a variant is a
:func:`dataclasses.replace`, nothing is registered anywhere) and builds, in one process and one
rclpy context, the simulation bridge (:class:`~phri_sim.ros.bridge.SimBridgeNode`, given the
scenario itself, ``lockstep: true``), the real
:class:`contact_estimation.node.ContactEstimationNode` and the real
:class:`wholebody_controller.node.WholeBodyControllerNode` (or, with ``controller="stub"``, a
stub that publishes zero commands), all with their parameters as ``parameter_overrides`` (the
scenario's, :mod:`phri_sim.scenarios.catalogue`) and ``use_sim_time``. Each control period:

1. the bridge advances the physics one period (5 ms steps) and publishes joint states,
   odometry, the skins (an untouched patch every 10th period only) and the ground truth (to
   subscribers), stamped with the simulation time; with ``sensor_transport="direct"`` (default)
   it hands the taxel arrays, joint states and odometry to the nodes' callbacks instead
   (:data:`~phri_sim.ros.run_options.SENSOR_TRANSPORTS`);
2. the executor spins until the controller holds this period's contact states (same stamp), joint
   state and odometry;
3. the bridge publishes ``/clock``; the controller's sim-time timer fires and its three commands
   reach the bridge, which applies them during the next period.

Steps 2 and 3 wait on what this period expects, not on the wall clock
(:mod:`phri_sim.ros.lockstep`): a run is deterministic for a seed and the same on a busy host;
only a dead node ends it (:class:`~phri_sim.ros.lockstep.LockStepError`). A caller can add nodes
(``recorder``: a factory called with the context, e.g. one that subscribes every topic for an
MCAP recording) and follow progress (``progress(sim_time, duration)`` once per simulated second).
The options' ``fault`` / ``fault_time`` inject a sensor fault in the bridge
(:mod:`phri_sim.world.sensor_faults`); a frame or joint state the fault corrupted is not waited
for in step 2 (downstream may refuse it), nor is the contact state of a frame the contact
estimation refused (plausibility, corruption: it withholds that link's state). The metrics
(:mod:`phri_sim.evaluation.metrics`) also read the person↔robot contact forces after every
physics step (:mod:`phri_sim.evaluation.body_forces`).

Command line: ``python -m phri_sim.ros.runner waltz [--short] [--seed N] [--out metrics.json]
[--fault FAULT] [--fault-time T]``.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import math
import sys
import time
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import numpy as np
import rclpy
from rclpy.context import Context
from rclpy.node import Node
from rclpy.parameter import Parameter
from sensor_msgs.msg import PointCloud2
from std_msgs.msg import Float64MultiArray

from phri_common.contact import ContactMessageError, msg_to_contact
from phri_common.records import ContactState
from phri_description.description import SKIN_LINKS
from phri_sim.evaluation.metrics import scenario_metrics
from phri_sim.ros.bridge import ARM_TOPICS, SimBridgeNode
from phri_sim.ros.lockstep import LockStep, LockStepError, Missing
from phri_sim.ros.run_options import FIDELITIES, SENSOR_TRANSPORTS, RunOptions, run_summary
from phri_sim.scenarios.catalogue import (
    SCENARIOS,
    Scenario,
    scenario_named,
)
from phri_sim.world.actuators import DEFAULT_PLANT, PLANTS
from phri_sim.world.sensor_faults import DEFAULT_FAULT_TIME, FAULT_KINDS

__all__ = ["LockStepError", "RunOptions", "ScenarioRun", "run_scenario"]

Recorder = Callable[[Context], Node]
Progress = Callable[[float, float], None]

RUNNER_INPUT_TIMEOUT = 2.0
"""Input timeouts [s] given to the controller in lock-step: its staleness check uses the wall
clock, which a loaded machine must not trip (the bridge's sim-time watchdog still applies)."""
COMMAND_TOPICS = {"base": "/cmd_vel", **ARM_TOPICS}
"""The bridge's command channels and their topics (for what a phase still waits for)."""


class ZeroCommandStub(Node):
    """Stand-in controller: publishes zero commands on every sim-time tick (100 Hz)."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__("wholebody_controller", **kwargs)
        from geometry_msgs.msg import Twist

        self.cmd_pub = self.create_publisher(Twist, "/cmd_vel", 10)
        self.arm_pubs = [
            self.create_publisher(Float64MultiArray, f"{side}/forward_velocity_controller/commands",
                                  10)
            for side in ("left", "right")
        ]
        self._twist = Twist
        self.timer = self.create_timer(0.01, self.tick)

    def tick(self) -> None:
        self.cmd_pub.publish(self._twist())
        for pub in self.arm_pubs:
            pub.publish(Float64MultiArray(data=[0.0] * 6))




def _params(values: Mapping[str, Any]) -> list[Parameter]:
    return [Parameter(name, value=value) for name, value in values.items()]


def _estimation_node(context: Context, scenario: Scenario, subscribe: bool) -> Node:
    """The contact estimation node with the scenario's parameters, on sim time, no markers;
    subscribed to the taxel topics when ``subscribe``."""
    from contact_estimation.node import ContactEstimationNode

    return ContactEstimationNode(context=context, parameter_overrides=[
        Parameter("use_sim_time", value=True), Parameter("publish_markers", value=False),
        Parameter("subscribe_taxels", value=subscribe),
        *_params(scenario.estimation_parameters),
    ])


def _controller_node(kind: str, context: Context, scenario: Scenario, direct: bool) -> Node:
    """The whole-body controller node (``kind`` 'node') with the scenario's parameters and the
    runner's input timeouts, taking joint states and odometry from the bridge's hand-off when
    ``direct``, or the zero-command stub ('stub'), on sim time."""
    sim_time = Parameter("use_sim_time", value=True)
    if kind == "stub":
        return ZeroCommandStub(context=context, parameter_overrides=[sim_time])
    from wholebody_controller.node import WholeBodyControllerNode

    params = {
        **scenario.controller_parameters,
        "contact_timeout": RUNNER_INPUT_TIMEOUT,
        "joint_state_timeout": RUNNER_INPUT_TIMEOUT,
        "odom_timeout": RUNNER_INPUT_TIMEOUT,
    }
    return WholeBodyControllerNode(context=context, direct_state_inputs=direct,
                                   parameter_overrides=[sim_time, *_params(params)])




class ScenarioRun:
    """One lock-step run of ``scenario`` with ``options`` through the real nodes (module
    docstring).

    Args:
        scenario: what happens (the person's script, the robot's start, the nodes' parameters).
        options: how it is simulated (:class:`~phri_sim.ros.run_options.RunOptions`; None:
            the defaults).
        context: an initialised rclpy context the run's nodes live in.
        recorder: builds one more node in the context (e.g. a recorder), spun with the others.
        progress: called with (sim time [s], duration [s]) once per simulated second.
    """

    def __init__(self, scenario: Scenario, options: RunOptions | None = None, *,
                 context: Context, recorder: Recorder | None = None,
                 progress: Progress | None = None) -> None:
        self.scenario = scenario
        self.options = options = options or RunOptions()
        self.duration = options.length(scenario)
        self.context = context
        self.progress = progress
        self.bridge = SimBridgeNode(scenario=scenario, context=context,
                                    parameter_overrides=_params(options.bridge_parameters(scenario)))
        direct = options.sensor_transport == "direct"
        self.is_stub = options.controller == "stub"
        self.estimation = _estimation_node(context, scenario, subscribe=not direct)
        self.controller = _controller_node(options.controller, context, scenario, direct)
        if direct:
            self.bridge.add_taxel_listener(self.estimation.on_frame)  # type: ignore[attr-defined]
            if not self.is_stub:
                self.bridge.add_state_listener(self.controller.on_joints,  # type: ignore[attr-defined]
                                               self.controller.on_odom)  # type: ignore[attr-defined]
        self.probe = Node("phri_sim_runner", context=context)
        # The real controller already decodes every contact state it is sent: the runner reads
        # them there (one DDS hop and three decodes per period less). Only the stub needs the
        # runner's own subscription to know when this period's estimates are out.
        self._own_estimates: dict[str, ContactState] = {}
        if self.is_stub:
            for link in SKIN_LINKS:
                self.probe.create_subscription(
                    PointCloud2, f"contacts/{link}",
                    lambda msg, link=link: self._on_estimate(link, msg), 10,
                )
        self.extra: list[Node] = [recorder(context)] if recorder is not None else []
        from rclpy.experimental.events_executor import EventsExecutor

        self.executor = EventsExecutor(context=context)
        nodes = (self.bridge, self.estimation, self.controller, self.probe, *self.extra)
        for node in nodes:
            self.executor.add_node(node)
        self.lockstep = LockStep(self.executor, context, nodes,
                                 warn=self.probe.get_logger().warning)
        """Waits for each phase (:mod:`phri_sim.ros.lockstep`)."""
        self.metrics = scenario_metrics(scenario, self.bridge.sim,
                                        options.watched_time(self.bridge.shove.spec))
        self._last_command = np.zeros(15)
        self._fresh_links: set[str] = set(SKIN_LINKS)
        self._skip_joints = False
        self.wall_time = 0.0

    def _on_estimate(self, link: str, msg: PointCloud2) -> None:
        with contextlib.suppress(ContactMessageError):
            self._own_estimates[link] = msg_to_contact(msg)

    @property
    def estimates(self) -> dict[str, ContactState]:
        """The latest contact state per link as estimated by contact_estimation."""
        contacts = None if self.is_stub else getattr(self.controller, "contacts", None)
        return self._own_estimates if contacts is None else contacts

    # -- lock-step phases -----------------------------------------------------------------------
    def wait_for(self, missing: Missing, what: str) -> None:
        """Spin the run's executor until ``missing()`` is empty (:meth:`LockStep.wait
        <phri_sim.ros.lockstep.LockStep.wait>`; public so benchmarks can time it)."""
        self.lockstep.wait(missing, what, self.bridge.sim.time)

    def _refused(self) -> dict[str, int]:
        """Frames the contact estimation refused so far, per patch (plausibility, corruption)."""
        return dict(getattr(self.estimation, "refused_frames", {}))

    def _missing_inputs(self, stamp_ns: int, marks: tuple[Any, ...],
                        refused: dict[str, int]) -> list[str]:
        """What the controller does not hold yet of this period's contacts, joint state and
        odometry (topic names; empty when it holds them all). A link whose patch's frame the
        estimation refused since ``refused`` (its counts before the period) gets no contact
        state this period and is not waited for."""
        estimates = self.estimates
        out = []
        withheld: set[str] | None = None
        for link in SKIN_LINKS:
            state = estimates.get(link)
            if state is None or (link in self._fresh_links and state.stamp_ns != stamp_ns):
                if withheld is None:
                    withheld = self._withheld_links(refused)
                if link not in withheld:
                    out.append(f"contacts/{link}")
        ctrl = self.controller
        if hasattr(ctrl, "odom_time") and hasattr(ctrl, "arm_time"):
            if not (self._skip_joints or np.min(ctrl.arm_time) != marks[1]):
                out.append("/joint_states")
            if ctrl.odom_time == marks[0]:
                out.append("/odom")
        return out

    def _withheld_links(self, refused: dict[str, int]) -> set[str]:
        """Links whose patch had a frame refused since the counts ``refused``."""
        now = self._refused()
        patch_link = self.bridge.sim.skins.patch_link
        return {patch_link[p] for p, n in now.items()
                if n > refused.get(p, 0) and p in patch_link}

    def _marks(self) -> tuple[Any, ...]:
        ctrl = self.controller
        return (getattr(ctrl, "odom_time", None), float(np.min(getattr(ctrl, "arm_time", [0.0]))))

    def step(self) -> None:
        """One control period (module docstring)."""
        bridge = self.bridge
        marks = self._marks()
        refused = self._refused()
        bridge.advance(1, clock=False)
        stamp = bridge.stamp_ns
        patch_link = bridge.sim.skins.patch_link
        # A frame or joint state an injected fault corrupted this period may be refused
        # downstream (no contact state, no joint-state update): the lock-step does not wait for it.
        faulted = bridge.faults.changed_at(bridge.fault_clock)
        self._fresh_links = {patch_link[p] for p in bridge.published_patches if p not in faulted}
        self._skip_joints = "joint_states" in faulted
        self.wait_for(lambda: self._missing_inputs(stamp, marks, refused), "sensor data")
        before = dict(bridge.commands_received)
        bridge.publish_clock()
        self.wait_for(lambda: [COMMAND_TOPICS[k] for k in before
                               if bridge.commands_received[k] <= before[k]],
                      "controller commands")
        self._last_command = bridge.sim.watchdog.received(bridge.sim.time)
        self.metrics.sample(bridge.sim, self._last_command, self.estimates)

    def _undiscovered(self) -> list[str]:
        """The topics the run needs that nobody subscribes to yet: with the direct hand-off the
        estimator's outputs, with topics its inputs; ``/clock``."""
        inputs = [f"contacts/{link}" for link in SKIN_LINKS] \
            if self.options.sensor_transport == "direct" \
            else [f"skin/{p}/taxels" for p in self.bridge.sim.patches]
        return [t for t in [*inputs, "/clock"] if self.bridge.count_subscribers(t) == 0]

    def run(self) -> dict[str, Any]:
        """Run to the end; return the metrics (also the run's settings and timing)."""
        periods = round(self.duration / self.bridge.period)
        # Let discovery settle and the nodes see the initial state before the first tick.
        self.wait_for(self._undiscovered, "discovery")
        start = time.perf_counter()
        cpu_start = time.process_time()
        next_report = 1.0
        for _ in range(periods):
            self.step()
            if self.progress is not None and self.bridge.sim.time >= next_report - 1e-9:
                self.progress(self.bridge.sim.time, self.duration)
                next_report += 1.0
        self.wall_time = time.perf_counter() - start
        return self._summary(time.process_time() - cpu_start)

    def _summary(self, cpu_time: float) -> dict[str, Any]:
        """The metrics with the run's settings and timing (CPU time [s] of this process)."""
        summary = run_summary(
            self.metrics, self.scenario, self.options,
            controller="stub (zero commands)" if self.is_stub else "wholebody_controller",
            faults=self.bridge.faults, shove=self.bridge.shove, sim_time=self.bridge.sim.time,
            wall_time=self.wall_time, cpu_time=cpu_time)
        summary["commands_refused"] = self.bridge.commands_refused
        return summary

    def close(self) -> None:
        """Destroy every node (the controller sends its final zero command) and the executor."""
        for node in (*self.extra, self.probe, self.controller, self.estimation, self.bridge):
            node.destroy_node()
        self.executor.shutdown()


def run_scenario(
    scenario: Scenario | str,
    options: RunOptions | None = None,
    *,
    context: Context | None = None,
    output: str | Path | None = None,
    recorder: Recorder | None = None,
    progress: Progress | None = None,
) -> dict[str, Any]:
    """Run ``scenario`` (a value, or a name of :data:`~phri_sim.scenarios.catalogue.SCENARIOS`)
    with ``options`` (:class:`ScenarioRun`) and return its metrics; write them as JSON to
    ``output`` if given. Creates (and shuts down) its own context unless one is given.
    """
    if isinstance(scenario, str):
        scenario = scenario_named(scenario)
    own = context is None
    if own:
        context = Context()
        rclpy.init(context=context)
    assert context is not None
    run = ScenarioRun(scenario, options, context=context, recorder=recorder, progress=progress)
    try:
        metrics = run.run()
    finally:
        run.close()
        if own:
            context.try_shutdown()
    if output is not None:
        Path(output).write_text(json.dumps(metrics, indent=2, allow_nan=True) + "\n",
                                encoding="utf-8")
    return metrics


def _arguments(argv: list[str] | None) -> argparse.Namespace:
    """The command line of :func:`main`."""
    parser = argparse.ArgumentParser(description=main.__doc__)
    parser.add_argument("scenario", choices=sorted(SCENARIOS))
    parser.add_argument("--short", action="store_true", help="the shortened CI length")
    parser.add_argument("--duration", type=float, default=None, help="length [s]")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--fidelity", choices=sorted(FIDELITIES), default="fast",
                        help="fast: 5 ms physics, 100 Hz skin; paper: 2 ms, 500 Hz")
    parser.add_argument("--skin-driver", action="store_true",
                        help="the real skin driver in the loop (protocol frames of raw counts)")
    parser.add_argument("--skin-rate", type=float, default=None,
                        help="skin sampling rate [Hz] (default: the fidelity's)")
    parser.add_argument("--skin-idle-decimation", type=int, default=None,
                        help="sample an untouched patch every N-th time (1 = always)")
    parser.add_argument("--stub", action="store_true", help="zero-command stub controller")
    parser.add_argument("--sensor-transport", choices=SENSOR_TRANSPORTS, default="direct",
                        help="taxel arrays, joint states, odometry to the nodes: direct hand-off "
                        "or their topics")
    parser.add_argument("--viewer", action="store_true", help="MuJoCo viewer (needs a display)")
    parser.add_argument("--out", default=None, help="metrics JSON path")
    parser.add_argument("--fault", choices=FAULT_KINDS, default=None,
                        help="inject a sensor fault (docs/phri_sim.md, Fault injection)")
    parser.add_argument("--fault-time", type=float, default=DEFAULT_FAULT_TIME,
                        help="sim time the fault starts [s] (default 5)")
    parser.add_argument("--fault-patch", default="", help="the patch a patch fault acts on")
    parser.add_argument("--fault-value", type=float, default=0.0,
                        help="the fault's factor / noise / value (0 = the kind's default)")
    parser.add_argument("--shove", default="", help="FORCE N@TIME s+DURATION s[:push|:force]")
    parser.add_argument("--plant", choices=sorted(PLANTS), default=DEFAULT_PLANT,
                        help="realistic: the drives' latency, ramps and lag and the skin "
                        "driver's moving average (default); ideal: servos follow every command "
                        "at once")
    return parser.parse_args(argv)


def main(argv: list[str] | None = None) -> None:
    """``python -m phri_sim.ros.runner SCENARIO``: run one scenario headless and print its
    metrics."""
    args = _arguments(argv)

    def report(t: float, total: float) -> None:
        if math.isclose(t % 10.0, 0.0, abs_tol=1e-6) or t >= total - 1e-9:
            print(f"  t = {t:5.1f} / {total:.1f} s", file=sys.stderr)

    options = RunOptions(
        duration=args.duration, short=args.short, seed=args.seed, fidelity=args.fidelity,
        skin_driver=args.skin_driver, skin_rate_hz=args.skin_rate,
        skin_idle_decimation=args.skin_idle_decimation,
        controller="stub" if args.stub else "node", sensor_transport=args.sensor_transport,
        viewer=args.viewer, fault=args.fault or "", fault_time=args.fault_time,
        fault_patch=args.fault_patch, fault_value=args.fault_value, shove=args.shove,
        plant=args.plant,
    )
    metrics = run_scenario(args.scenario, options, output=args.out, progress=report)
    print(json.dumps(metrics, indent=2))


if __name__ == "__main__":
    main()
