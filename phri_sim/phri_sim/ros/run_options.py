"""What one lock-step run is asked to do, as a value: :class:`RunOptions` (frozen, validated).

A run is a :class:`~phri_sim.scenarios.catalogue.Scenario` (what happens) and its options (how it
is simulated: length, seed, time resolution, sensor path, controller, fault). Both are frozen
dataclasses; a variant is made with :func:`dataclasses.replace` (a scenario with another
parameter set, a run with the zero-command stub), never by changing a shared registry.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from phri_common import paper
from phri_sim.evaluation.metrics import MetricsRecorder
from phri_sim.scenarios.catalogue import Scenario
from phri_sim.world.actuators import DEFAULT_PLANT, PLANTS
from phri_sim.world.sensor_faults import DEFAULT_FAULT_TIME, SensorFaults
from phri_sim.world.shove import Shove, ShoveSpec

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


SENSOR_TRANSPORTS = ("direct", "topics")
"""How the bridge's sensor data reach the nodes in a lock-step run (``sensor_transport``):
``direct`` = the bridge hands each taxel array to contact estimation's ``on_frame`` (the composed
skin node's path, phri_bringup.skin_contact_node) and each joint state and odometry message to
the controller's ``on_joints`` / ``on_odom`` (the controller built with ``direct_state_inputs``:
it does not subscribe those topics), publishing those topics only to other subscribers (a
recorder); ``topics`` = all over their topics (serialised, DDS, deserialised). The contact
states, ``/clock`` and the commands cross DDS either way. Same inputs, same run
(test_skin_loop.py: identical metrics)."""

CONTROLLERS = ("node", "stub")
"""``node``: the real whole-body controller; ``stub``: a stand-in that commands zero (a
motionless robot, the baseline of the following metrics)."""
MOTIONLESS = "motionless (never commanded)"
"""The summary's ``controller`` of a run on the world alone
(:func:`phri_sim.ros.motionless.run_motionless`)."""


def _given(value: Any, default: Any) -> Any:
    """``value`` unless it is None."""
    return default if value is None else value


@dataclass(frozen=True)
class RunOptions:
    """How a scenario is run in lock-step (every field has the ``phri sim`` default).

    Attributes:
        duration: simulated length [s]; None: the scenario's (its CI length with ``short``).
        short: the scenario's shortened CI length (when ``duration`` is None).
        seed: seed of the skin noise (same seed → same run).
        fidelity: time resolution, a key of :data:`FIDELITIES`.
        skin_driver: the real skin driver in the loop (protocol frames of raw counts).
        skin_rate_hz: skin sampling rate [Hz]; None: the fidelity's.
        skin_idle_decimation: sample an untouched patch every N-th time; None: the fidelity's.
        physics_timestep: MuJoCo step [s]; None: the fidelity's.
        taxel_publish_rate_hz: taxel-array rate [Hz] (0 = every sample); None: the fidelity's.
        controller: one of :data:`CONTROLLERS`.
        sensor_transport: one of :data:`SENSOR_TRANSPORTS`.
        viewer: open the MuJoCo viewer (needs a display).
        fault: sensor fault to inject ('' = none; the bridge checks the kind).
        fault_time: sim time the fault starts [s].
        fault_patch: the patch a patch fault acts on ('' = every patch).
        fault_value: the fault's factor / noise / value (0 = the kind's default).
        shove: the partner's shove, ``FORCE N@TIME s+DURATION s[:kind]`` ('' = none;
            :mod:`phri_sim.world.shove`).
        protective_stop: the arms' own protective stop (false: arms that never stop
            themselves, for comparisons; bridge parameter ``protective_stop``).
        plant: what stands between the commands and the simulated robot, a key of
            :data:`phri_sim.world.actuators.PLANTS` (``realistic``: the drives' latency, ramps
            and lag, the skin driver's moving average; ``ideal``: none; docs/phri_sim.md,
            "Plant").
    """

    duration: float | None = None
    short: bool = False
    seed: int = 0
    fidelity: str = "fast"
    skin_driver: bool = False
    skin_rate_hz: float | None = None
    skin_idle_decimation: int | None = None
    physics_timestep: float | None = None
    taxel_publish_rate_hz: float | None = None
    controller: str = "node"
    sensor_transport: str = "direct"
    viewer: bool = False
    fault: str = ""
    fault_time: float = DEFAULT_FAULT_TIME
    fault_patch: str = ""
    fault_value: float = 0.0
    shove: str = ""
    protective_stop: bool = True
    plant: str = DEFAULT_PLANT

    def __post_init__(self) -> None:
        for name, allowed in (("fidelity", tuple(FIDELITIES)), ("controller", CONTROLLERS),
                              ("sensor_transport", SENSOR_TRANSPORTS), ("plant", tuple(PLANTS))):
            value = getattr(self, name)
            if value not in allowed:
                raise ValueError(f"{name} must be one of {', '.join(allowed)}, got {value!r}")

    def length(self, scenario: Scenario) -> float:
        """The run's simulated length [s] for ``scenario``."""
        if self.duration is not None:
            return self.duration
        return scenario.short_duration if self.short else scenario.duration

    def watched_time(self, shove: ShoveSpec | None) -> float | None:
        """From when the metrics' ``fault`` block watches [s]: the fault's time, else the start
        of ``shove`` (the run's, parsed from :attr:`shove`); ``None`` without either."""
        if self.fault:
            return float(self.fault_time)
        return None if shove is None else shove.time

    def bridge_parameters(self, scenario: Scenario) -> dict[str, Any]:
        """The simulation bridge's parameters for this run of ``scenario`` (lock-step)."""
        fid = FIDELITIES[self.fidelity]
        return {
            "lockstep": True, "scenario": scenario.name, "seed": self.seed,
            "viewer": self.viewer,
            "skin_rate_hz": _given(self.skin_rate_hz, fid.skin_rate_hz),
            "skin_idle_decimation": _given(self.skin_idle_decimation, fid.skin_idle_decimation),
            "physics_timestep": _given(self.physics_timestep, fid.physics_timestep),
            "taxel_publish_rate_hz": _given(self.taxel_publish_rate_hz,
                                            fid.taxel_publish_rate_hz),
            "skin_driver": self.skin_driver, "fault": self.fault,
            "fault_time": float(self.fault_time), "fault_patch": self.fault_patch,
            "fault_value": float(self.fault_value), "shove": self.shove,
            "protective_stop": self.protective_stop,
            "plant": self.plant,
        }


def run_summary(metrics: MetricsRecorder, scenario: Scenario, options: RunOptions, *,
                controller: str, faults: SensorFaults, shove: Shove, sim_time: float,
                wall_time: float, cpu_time: float) -> dict[str, Any]:
    """A run's metrics (``metrics.summary()``) with its settings and timing: ``sim_time`` [s]
    simulated in ``wall_time`` [s] and ``cpu_time`` [s] of the process (all its threads: less
    sensitive to other load on the machine than the wall clock); ``controller`` names what
    commanded the robot."""
    metrics.fault_changes = (faults.first_change, faults.changes)
    summary = metrics.summary()
    summary.update({
        "scenario": scenario.name,
        "duration": options.length(scenario),
        "wall_time": wall_time,
        "real_time_factor": sim_time / max(wall_time, 1e-9),
        "cpu_time": cpu_time,
        "real_time_factor_cpu": sim_time / max(cpu_time, 1e-9),
        "controller": controller,
        "fidelity": options.fidelity,
        "skin_driver": options.skin_driver,
        "sensor_transport": options.sensor_transport,
        "plant": options.plant,
        "partner": scenario.partner,
    })
    if faults.spec is not None:
        summary["fault"]["kind"] = faults.spec.kind
    if shove.spec is not None:
        summary["shove"] = {"spec": options.shove, "kind": shove.spec.kind,
                            "time": shove.spec.time, "duration": shove.spec.duration,
                            "peak_applied": shove.peak,
                            "direction": None if shove.direction is None
                            else shove.direction.tolist()}
        if faults.spec is None:
            summary["fault"]["kind"] = f"shove {options.shove}"
    return summary
