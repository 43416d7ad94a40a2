"""In-process scenario runner: bridge + contact estimation + controller on one executor, lock-step.

:func:`run_scenario` builds, in one process and one rclpy context, the simulation bridge
(:class:`~phri_sim.ros.bridge.SimBridgeNode`, ``lockstep: true``), the real
:class:`contact_estimation.node.ContactEstimationNode` and the real
:class:`wholebody_controller.node.WholeBodyControllerNode` (or, with ``controller="stub"``, a
stub that publishes zero commands), all with their parameters as ``parameter_overrides`` (the
scenario's paper values, :mod:`phri_sim.scenarios.catalogue`) and ``use_sim_time``. Each control
period:

1. the bridge advances the physics one period (5 ms steps) and publishes joint states,
   odometry, the skins (an untouched patch every 10th period only) and the ground truth (to
   subscribers), stamped with the simulation time; with ``sensor_transport="direct"`` (default)
   it hands the taxel arrays, joint states and odometry to the nodes' callbacks instead
   (:data:`SENSOR_TRANSPORTS`);
2. the executor spins until the controller holds this period's contact states (same stamp), joint
   state and odometry;
3. the bridge publishes ``/clock``; the controller's sim-time timer fires and its three commands
   reach the bridge, which applies them during the next period.

Nothing depends on the wall clock, so a run is deterministic for a seed. A caller can add nodes
(``recorder``: a factory called with the context, e.g. one that subscribes every topic for an
MCAP recording) and follow progress (``progress(sim_time, duration)`` once per simulated second).
``fault`` / ``fault_time`` inject a sensor fault in the bridge
(:mod:`phri_sim.world.sensor_faults`); a frame or joint state the fault corrupted is not waited for
in step 2 (downstream may refuse it). The metrics (:mod:`phri_sim.evaluation.metrics`) also read the
person↔robot contact forces after every physics step (:mod:`phri_sim.evaluation.body_forces`).

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
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import rclpy
from numpy.typing import NDArray
from rclpy.context import Context
from rclpy.node import Node
from rclpy.parameter import Parameter
from sensor_msgs.msg import PointCloud2
from std_msgs.msg import Float64MultiArray

from phri_common import paper
from phri_common.contact import ContactMessageError, msg_to_contact
from phri_common.records import ContactState
from phri_description.description import SKIN_LINKS
from phri_sim.evaluation.following_metrics import TEMPO_BARS
from phri_sim.evaluation.metrics import MetricsRecorder
from phri_sim.ros.bridge import SimBridgeNode
from phri_sim.scenarios.catalogue import SCENARIOS, WALTZ_FORCE, WALTZ_LINK, Scenario
from phri_sim.world.sensor_faults import DEFAULT_FAULT_TIME, FAULT_KINDS

Recorder = Callable[[Context], Node]
Progress = Callable[[float, float], None]

SYNC_TIMEOUT = 5.0
"""Wall time [s] a lock-step phase may wait for messages before the run is declared stuck."""
RUNNER_INPUT_TIMEOUT = 2.0
"""Input timeouts [s] given to the controller in lock-step: its staleness check uses the wall
clock, which a loaded machine must not trip (the bridge's sim-time watchdog still applies)."""
SKIN_RATE_HZ = 100.0
"""Default taxel rate in lock-step runs: one frame per control period (the controller uses only
the newest frame); the bridge's own default, used when free-running, is the paper's 500 Hz."""


SKIN_IDLE_DECIMATION = 10
"""In lock-step runs an untouched skin patch is published every 10th period only (bridge
parameter ``skin_idle_decimation``): its frames carry only sensor noise, far below the contact
threshold, so the contact state downstream is the same, and two of three patches are idle most of
the time. Touched patches, and the first frame after a release, go out every period."""


PHYSICS_TIMESTEP = 0.005
"""MuJoCo step of lock-step runs [s]: two steps per control period, every sample of the 100 Hz
skin on a step (the bridge's own default, 2 ms, serves the 500 Hz skin when free-running). The
scenario metrics agree with 2 ms runs (docs/phri_sim.md)."""


@dataclass(frozen=True)
class Fidelity:
    """Time resolution of a lock-step run (``--fidelity``, docs/phri_sim.md).

    Attributes:
        physics_timestep: MuJoCo step [s].
        skin_rate_hz: skin sampling rate [Hz] (every sample reaches the skin driver's filter
            when it is in the loop).
        taxel_publish_rate_hz: rate of the taxel arrays to contact estimation [Hz] (0 = every
            sample).
        skin_idle_decimation: an untouched patch is sampled every N-th time only.
    """

    physics_timestep: float
    skin_rate_hz: float
    taxel_publish_rate_hz: float
    skin_idle_decimation: int


FIDELITIES = {
    "fast": Fidelity(PHYSICS_TIMESTEP, SKIN_RATE_HZ, 0.0, SKIN_IDLE_DECIMATION),
    "paper": Fidelity(0.002, paper.SKIN_RATE_HZ, paper.CONTROL_RATE_HZ, 5 * SKIN_IDLE_DECIMATION),
}
"""``fast``: 5 ms physics, the skin sampled once per control period (100 Hz). ``paper``: the
paper's 2 ms physics and 500 Hz skin; contact estimation gets the newest reading once per
control period (the estimator keeps no state between frames and the controller uses only the
newest estimate, so the frames in between would change nothing downstream;
test_skin_loop.py checks it), while the skin driver, when in the loop, filters all of them."""


class LockStepError(RuntimeError):
    """A lock-step phase did not complete (a node stopped answering)."""


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


FloatArray = NDArray[np.float64]


def _given(value: Any, default: Any) -> Any:
    """``value`` unless it is None."""
    return default if value is None else value


def _params(values: dict[str, Any]) -> list[Parameter]:
    return [Parameter(name, value=value) for name, value in values.items()]


SENSOR_TRANSPORTS = ("direct", "topics")
"""How the bridge's sensor data reach the nodes in a lock-step run (``sensor_transport``):
``direct`` = the bridge hands each taxel array to contact estimation's ``on_frame`` (the composed
skin node's path, phri_bringup.skin_contact_node) and each joint state and odometry message to
the controller's ``on_joints`` / ``on_odom``, publishing those topics only to other subscribers
(a recorder); ``topics`` = all over their topics (serialised, DDS, deserialised). The contact
states, ``/clock`` and the commands cross DDS either way. Same inputs, same run
(test_skin_loop.py: identical metrics)."""


def _estimation_node(context: Context, scenario: Scenario, subscribe: bool) -> Node:
    """The contact estimation node with the scenario's parameters, on sim time, no markers;
    subscribed to the taxel topics when ``subscribe``."""
    from contact_estimation.node import ContactEstimationNode

    return ContactEstimationNode(context=context, parameter_overrides=[
        Parameter("use_sim_time", value=True), Parameter("publish_markers", value=False),
        Parameter("subscribe_taxels", value=subscribe),
        *_params(scenario.estimation_parameters),
    ])


def _controller_node(kind: str, context: Context, scenario: Scenario) -> Node:
    """The whole-body controller node (``kind`` 'node') with the scenario's parameters and the
    runner's input timeouts, or the zero-command stub ('stub'), on sim time."""
    sim_time = Parameter("use_sim_time", value=True)
    if kind == "node":
        from wholebody_controller.node import WholeBodyControllerNode

        params = {
            **scenario.controller_parameters,
            "contact_timeout": RUNNER_INPUT_TIMEOUT,
            "joint_state_timeout": RUNNER_INPUT_TIMEOUT,
            "odom_timeout": RUNNER_INPUT_TIMEOUT,
        }
        return WholeBodyControllerNode(context=context,
                                       parameter_overrides=[sim_time, *_params(params)])
    if kind == "stub":
        return ZeroCommandStub(context=context, parameter_overrides=[sim_time])
    raise ValueError(f"controller must be 'node' or 'stub', got {kind!r}")


def _hand_states_over(bridge: SimBridgeNode, controller: Any) -> None:
    """The bridge calls the controller's joint-state and odometry callbacks itself; the
    controller's own subscriptions to those topics are removed (a message would otherwise
    arrive twice, and the topics go out only to other subscribers)."""
    for sub in list(controller.subscriptions):
        if sub.topic_name in ("/joint_states", "/odom"):
            controller.destroy_subscription(sub)
    bridge.add_state_listener(controller.on_joints, controller.on_odom)


def _dance_ranges(params: Mapping[str, Any]) -> FloatArray | None:
    """(15, 2) joint bands q_dance ± q_dance_range [rad] for the arms (base unbounded) when the
    controller's ``q_dance_enabled``; else ``None``."""
    if not params.get("q_dance_enabled"):
        return None
    q = np.array(params["q_dance"], dtype=np.float64)
    r = float(params["q_dance_range"])
    ranges = np.full((15, 2), [-np.inf, np.inf])
    ranges[3:, 0], ranges[3:, 1] = q - r, q + r
    return ranges


def _metrics(scenario: Scenario, sim: Any, fault_time: float | None) -> MetricsRecorder:
    """The run's metrics recorder, watching every physics step of ``sim``."""
    params = scenario.controller_parameters
    desired = params.get(f"{WALTZ_LINK}.desired_force")
    limit = float(params.get("velocity_limit", paper.VELOCITY_LIMIT))
    per_axis = params.get("velocity_limits")
    metrics = MetricsRecorder(
        scenario.metrics,
        limit if per_axis is None else np.minimum(np.asarray(per_axis, dtype=float), limit),
        _dance_ranges(params), fault_time=fault_time,
        desired_force=WALTZ_FORCE if desired is None else float(np.linalg.norm(desired)),
        bars=TEMPO_BARS if scenario.name == "waltz_tempo" else None,
    )
    metrics.watch(sim)
    return metrics


class ScenarioRun:
    """One lock-step run of a scenario through the real nodes (module docstring)."""

    def __init__(
        self,
        name: str,
        *,
        context: Context,
        duration: float | None = None,
        short: bool = False,
        seed: int = 0,
        fidelity: str = "fast",
        skin_driver: bool = False,
        skin_rate_hz: float | None = None,
        skin_idle_decimation: int | None = None,
        physics_timestep: float | None = None,
        taxel_publish_rate_hz: float | None = None,
        controller: str = "node",
        sensor_transport: str = "direct",
        viewer: bool = False,
        recorder: Recorder | None = None,
        progress: Progress | None = None,
        fault: str = "",
        fault_time: float = DEFAULT_FAULT_TIME,
    ) -> None:
        if name not in SCENARIOS:
            raise ValueError(f"unknown scenario {name!r}; known: {', '.join(SCENARIOS)}")
        self.scenario = sc = SCENARIOS[name]
        self.duration = duration if duration is not None else (
            sc.short_duration if short else sc.duration
        )
        self.context = context
        self.progress = progress
        if fidelity not in FIDELITIES:
            raise ValueError(f"fidelity must be one of {', '.join(FIDELITIES)}, got {fidelity!r}")
        fid = FIDELITIES[fidelity]
        if sensor_transport not in SENSOR_TRANSPORTS:
            raise ValueError(f"sensor_transport must be one of {', '.join(SENSOR_TRANSPORTS)}, "
                             f"got {sensor_transport!r}")
        self.sensor_transport = sensor_transport
        self.fidelity, self.skin_driver = fidelity, skin_driver
        self.bridge = SimBridgeNode(context=context, parameter_overrides=_params({
            "lockstep": True, "scenario": name, "seed": seed, "viewer": viewer,
            "skin_rate_hz": _given(skin_rate_hz, fid.skin_rate_hz),
            "skin_idle_decimation": _given(skin_idle_decimation, fid.skin_idle_decimation),
            "physics_timestep": _given(physics_timestep, fid.physics_timestep),
            "taxel_publish_rate_hz": _given(taxel_publish_rate_hz, fid.taxel_publish_rate_hz),
            "skin_driver": skin_driver, "fault": fault, "fault_time": float(fault_time),
        }))
        direct = sensor_transport == "direct"
        self.estimation = _estimation_node(context, sc, subscribe=not direct)
        self.controller = _controller_node(controller, context, sc)
        if direct:
            self.bridge.add_taxel_listener(self.estimation.on_frame)  # type: ignore[attr-defined]
            if controller == "node":
                _hand_states_over(self.bridge, self.controller)
        self.is_stub = controller == "stub"
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
        for node in (self.bridge, self.estimation, self.controller, self.probe, *self.extra):
            self.executor.add_node(node)
        self.metrics = _metrics(sc, self.bridge.sim, float(fault_time) if fault else None)
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
    def spin_until(self, condition: Callable[[], bool], what: str) -> None:
        """Spin the run's executor until ``condition()`` holds; :class:`LockStepError` naming
        ``what`` after :data:`SYNC_TIMEOUT` [s] of wall time (public so benchmarks can time it)."""
        deadline = time.monotonic() + SYNC_TIMEOUT
        while not condition():
            if time.monotonic() > deadline:
                raise LockStepError(f"lock-step: timed out waiting for {what} at sim time "
                                    f"{self.bridge.sim.time:.3f} s")
            self.executor.spin_once(timeout_sec=0.05)

    def _inputs_ready(self, stamp_ns: int, marks: tuple[Any, ...]) -> bool:
        """The controller holds this period's contacts, joint state and odometry."""
        estimates = self.estimates
        for link in SKIN_LINKS:
            state = estimates.get(link)
            if state is None or (link in self._fresh_links and state.stamp_ns != stamp_ns):
                return False
        ctrl = self.controller
        if hasattr(ctrl, "odom_time") and hasattr(ctrl, "arm_time"):
            joints = self._skip_joints or np.min(ctrl.arm_time) != marks[1]
            return bool(ctrl.odom_time != marks[0] and joints)
        return True

    def _marks(self) -> tuple[Any, ...]:
        ctrl = self.controller
        return (getattr(ctrl, "odom_time", None), float(np.min(getattr(ctrl, "arm_time", [0.0]))))

    def step(self) -> None:
        """One control period (module docstring)."""
        bridge = self.bridge
        marks = self._marks()
        bridge.advance(1, clock=False)
        stamp = bridge.stamp_ns
        patch_link = bridge.sim.skins.patch_link
        # A frame or joint state an injected fault corrupted this period may be refused
        # downstream (no contact state, no joint-state update): the lock-step does not wait for it.
        faulted = bridge.faults.changed_at(bridge.fault_clock)
        self._fresh_links = {patch_link[p] for p in bridge.published_patches if p not in faulted}
        self._skip_joints = "joint_states" in faulted
        self.spin_until(lambda: self._inputs_ready(stamp, marks), "sensor data")
        before = dict(bridge.commands_received)
        bridge.publish_clock()
        self.spin_until(
            lambda: all(bridge.commands_received[k] > before[k] for k in before),
            "controller commands",
        )
        self._last_command = bridge.sim.watchdog.received(bridge.sim.time)
        self.metrics.sample(bridge.sim, self._last_command, self.estimates)

    def run(self) -> dict[str, Any]:
        """Run to the end; return the metrics (also the run's settings and timing)."""
        periods = round(self.duration / self.bridge.period)
        # Let discovery settle and the nodes see the initial state before the first tick.
        # Direct hand-off: the estimator's outputs must be subscribed; topics: its inputs.
        inputs = [f"contacts/{link}" for link in SKIN_LINKS] if self.sensor_transport == "direct" \
            else [f"skin/{p}/taxels" for p in self.bridge.sim.patches]
        self.spin_until(lambda: all(
            self.bridge.count_subscribers(topic) > 0 for topic in [*inputs, "/clock"]
        ), "discovery")
        start = time.perf_counter()
        cpu_start = time.process_time()
        next_report = 1.0
        for _ in range(periods):
            self.step()
            if self.progress is not None and self.bridge.sim.time >= next_report - 1e-9:
                self.progress(self.bridge.sim.time, self.duration)
                next_report += 1.0
        self.wall_time = time.perf_counter() - start
        cpu_time = time.process_time() - cpu_start
        faults = self.bridge.faults
        self.metrics.fault_changes = (faults.first_change, faults.changes)
        summary = self.metrics.summary()
        summary.update({
            "scenario": self.scenario.name,
            "duration": self.duration,
            "wall_time": self.wall_time,
            "real_time_factor": self.bridge.sim.time / max(self.wall_time, 1e-9),
            # CPU time of this process (all its threads): less sensitive to other load on the
            # machine than the wall clock; on an idle machine the two factors come close.
            "cpu_time": cpu_time,
            "real_time_factor_cpu": self.bridge.sim.time / max(cpu_time, 1e-9),
            "controller": "stub (zero commands)" if self.is_stub else "wholebody_controller",
            "fidelity": self.fidelity,
            "skin_driver": self.skin_driver,
            "sensor_transport": self.sensor_transport,
            "commands_refused": self.bridge.commands_refused,
        })
        if self.bridge.faults.spec is not None:
            summary["fault"]["kind"] = self.bridge.faults.spec.kind
        return summary

    def close(self) -> None:
        """Destroy every node (the controller sends its final zero command) and the executor."""
        for node in (*self.extra, self.probe, self.controller, self.estimation, self.bridge):
            node.destroy_node()
        self.executor.shutdown()


def run_scenario(
    name: str,
    *,
    context: Context | None = None,
    output: str | Path | None = None,
    **options: Any,
) -> dict[str, Any]:
    """Run scenario ``name`` (options: see :class:`ScenarioRun`) and return its metrics; write them
    as JSON to ``output`` if given. Creates (and shuts down) its own context unless one is given.
    """
    own = context is None
    if own:
        context = Context()
        rclpy.init(context=context)
    assert context is not None
    run = ScenarioRun(name, context=context, **options)
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


def main(argv: list[str] | None = None) -> None:
    """``python -m phri_sim.ros.runner SCENARIO``: run one scenario headless and print its
    metrics."""
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
    args = parser.parse_args(argv)

    def report(t: float, total: float) -> None:
        if math.isclose(t % 10.0, 0.0, abs_tol=1e-6) or t >= total - 1e-9:
            print(f"  t = {t:5.1f} / {total:.1f} s", file=sys.stderr)

    metrics = run_scenario(
        args.scenario, output=args.out, duration=args.duration, short=args.short,
        seed=args.seed, fidelity=args.fidelity, skin_driver=args.skin_driver,
        skin_rate_hz=args.skin_rate,
        skin_idle_decimation=args.skin_idle_decimation,
        controller="stub" if args.stub else "node", sensor_transport=args.sensor_transport,
        viewer=args.viewer, progress=report,
        fault=args.fault or "", fault_time=args.fault_time,
    )
    print(json.dumps(metrics, indent=2))


if __name__ == "__main__":
    main()
