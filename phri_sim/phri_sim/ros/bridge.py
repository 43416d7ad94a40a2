"""ROS 2 bridge: the simulation behind the same topics as the real robot (thin node).

Publishes ``/joint_states`` (positions, velocities and the drives' efforts), ``/odom``,
``/clock`` and ``skin/<patch>/taxels``; subscribes ``/cmd_vel`` and
``<arm>/forward_velocity_controller/commands`` through the simulation's command watchdog;
publishes ground truth under ``sim/``, and each arm's state on ``/diagnostics`` as phri_hardware's
arm bridge does (:mod:`phri_sim.ros.arm_status`: the arms' own protective stop,
:mod:`phri_sim.world.protective_stop`), with ``sim/<arm>/unlock_protective_stop`` (the
operator's unlock). Two modes:

* free-running (``lockstep: false``): a wall-clock timer advances the simulation by one control
  period per tick, ``real_time_factor`` times faster than real time;
* lock-step (``lockstep: true``): nothing advances by itself; the owner (the in-process
  :mod:`phri_sim.ros.runner`) calls :meth:`SimBridgeNode.advance` and :meth:`publish_clock`, which
  makes the whole stack deterministic.

Interface, parameters and ground-truth topics: ``docs/phri_sim.md``.
"""

from __future__ import annotations

import array
import math
import sys
from collections.abc import Callable
from typing import Any

import numpy as np
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import (
    PointStamped,
    PoseArray,
    Twist,
    WrenchStamped,
)
from nav_msgs.msg import Odometry
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState, PointCloud2
from std_msgs.msg import Float64MultiArray
from std_srvs.srv import Trigger

from phri_common import paper
from phri_common.cdr import point_stamped_to_cdr, pose_array_to_cdr, wrench_stamped_to_cdr
from phri_common.params import ParamSpec, ParamValue
from phri_common.planar import quaternion_from_yaw
from phri_common.records import TaxelArray
from phri_common.ros_main import run_nodes
from phri_common.ros_params import declare_parameters
from phri_common.stamps import ns_to_stamp
from phri_common.taxels import TaxelCloudEncoder
from phri_sim.ros.arm_status import arm_status
from phri_sim.scenarios.catalogue import Q_HOME, SCENARIOS, Scenario, Script, start_scenario
from phri_sim.scenarios.playback import period_steps
from phri_sim.world.actuators import DEFAULT_PLANT, PLANTS
from phri_sim.world.protective_stop import ProtectiveStopConfig
from phri_sim.world.sensor_faults import DEFAULT_FAULT_TIME, FAULT_KINDS, FaultSpec, SensorFaults
from phri_sim.world.shove import Shove, ShoveSpec
from phri_sim.world.simulation import ARM_JOINTS, CommandError, SimConfig, Simulation
from phri_sim.world.skin_driver_loop import SkinLink
from phri_sim.world.skin_footprint import SkinConfig
from phri_sim.world.skin_pipeline import DriverPipeline

PARAMS: list[ParamSpec] = [
    ParamSpec("lockstep", False, "advance only when the owner calls advance() (in-process "
              "runner); otherwise a wall-clock timer drives the simulation", read_only=True),
    ParamSpec("scenario", "", "scenario whose person script runs ('' = person parked, robot "
              "at home): centring, sliding, whole_body, waltz", read_only=True),
    ParamSpec("seed", 0, "seed of the skin noise (same seed → same run)", low=0,
              high=2**31 - 1, read_only=True),
    ParamSpec("control_period", 0.01, "simulated time per advance / timer tick", unit="s",
              low=0.002, high=0.1, read_only=True),
    ParamSpec("physics_timestep", 0.002, "MuJoCo step; must divide control_period and the "
              "skin, state and ground-truth periods (the lock-step runner's fast fidelity uses "
              "0.005 with its 100 Hz skin)", unit="s", low=0.0005, high=0.005, read_only=True),
    ParamSpec("real_time_factor", 1.0, "free-running speed relative to the wall clock",
              low=0.01, high=100.0, read_only=True),
    ParamSpec("skin_rate_hz", paper.SKIN_RATE_HZ, "taxel-array publication rate (sim time)",
              unit="Hz",
              low=1.0, high=500.0, read_only=True),
    ParamSpec("skin_idle_decimation", 1, "read a patch nobody touches only once N skin periods "
              "have passed since its last reading (1 = every sample; the lock-step runner: "
              "every 100 ms, as an untouched patch's frame carries only noise below any "
              "contact threshold)", low=1, high=1000, read_only=True),
    ParamSpec("state_rate_hz", 100.0, "/joint_states, /odom and /clock rate (sim time)",
              unit="Hz", low=1.0, high=500.0, read_only=True),
    ParamSpec("ground_truth_rate_hz", 100.0, "ground-truth rate (sim time); 0 = off",
              unit="Hz", low=0.0, high=500.0, read_only=True),
    ParamSpec("command_timeout", 0.1, "a command older than this (sim time) reads as zero",
              unit="s", low=0.001, high=10.0, read_only=True),
    ParamSpec("skin_noise_std", 0.005, "per-taxel Gaussian noise of the sensor model",
              unit="N", low=0.0, high=10.0, read_only=True),
    ParamSpec("skin_gain_error_std", 0.05, "per-taxel relative gain error left by the factory "
              "calibration, standard deviation (sensor model)", low=0.0, high=0.5,
              read_only=True),
    ParamSpec("skin_offset_std", 20.0, "per-taxel zero offset, standard deviation (sensor "
              "model; removed by the driver's tare)", unit="count", low=0.0, high=5000.0,
              read_only=True),
    ParamSpec("skin_dead_taxels", 3, "taxels per patch that never respond, at seeded "
              "positions (sensor model)", low=0, high=1000, read_only=True),
    ParamSpec("skin_driver", False, "the real skin driver in the loop: each skin sample goes out "
              "as protocol-v1 frames of raw counts through skin_driver's parser, tare, "
              "calibration and moving average; off: the sensor model read with a perfect tare",
              read_only=True),
    ParamSpec("taxel_publish_rate_hz", 0.0, "largest rate of the taxel arrays (sim time); 0 = "
              "every skin sample. Samples in between still reach the skin driver's filter",
              unit="Hz", low=0.0, high=500.0, read_only=True),
    ParamSpec("skin_softness", 0.004, "thickness of the footprint model's compliant layer",
              unit="m", low=1e-4, high=0.05, read_only=True),
    ParamSpec("viewer", False, "open the MuJoCo viewer (needs a display)", read_only=True),
    ParamSpec("fault", "", "sensor fault to inject ('' = none): skin_blind, skin_stuck, "
              "force_spike, joint_jump, skin_frozen_noisy, skin_half_dead, skin_gain (docs: "
              "Fault injection)", read_only=True),
    ParamSpec("fault_patch", "", "the patch a skin_frozen_noisy / skin_half_dead / skin_gain "
              "fault acts on, the patch force_spike spikes ('' = every patch / the first "
              "touched)", read_only=True),
    ParamSpec("fault_value", 0.0, "skin_gain: the factor; skin_frozen_noisy: the relative "
              "noise; force_spike: the force [N]; joint_jump: the position [rad]; 0 = the "
              "kind's default", low=-1e39, high=1e39, read_only=True),
    ParamSpec("shove", "", "the partner shoves the waist: FORCE N@TIME s+DURATION s[:push|"
              ":force], e.g. 250N@20s+3s ('' = none; docs: Shove)", read_only=True),
    ParamSpec("fault_time", DEFAULT_FAULT_TIME, "sim time from which the fault acts",
              unit="s", low=0.0, high=1e6, read_only=True),
    ParamSpec("protective_stop", True, "the arms' own protective stop, as a UR16e's safety "
              "system does it (docs: Protective stop); false: arms that never stop themselves "
              "(comparisons only)", read_only=True),
    ParamSpec("plant", DEFAULT_PLANT, "what stands between the commands and the simulated robot: "
              "realistic (the base's latency, acceleration and jerk limits and velocity-loop lag; "
              "the UR16e's RTDE cycle and speedJ ramp; the skin through the driver's 500 Hz "
              "moving average) or ideal (servos follow every command at once, newest skin "
              "sample; docs: Plant)", read_only=True),
]

SENSOR_QOS = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)
ARM_TOPICS = {side: f"{side}/forward_velocity_controller/commands" for side in ARM_JOINTS}

TaxelListener = Callable[[str, TaxelArray], None]
"""Receives (patch name, taxel array) for every taxel array the bridge publishes."""
JointStateListener = Callable[[JointState], None]
OdometryListener = Callable[[Odometry], None]


def _check_divides(step: float, periods: dict[str, float]) -> None:
    """Every period must be a whole number (≥ 1) of physics steps: ValueError naming the
    parameter otherwise."""
    for name, period in periods.items():
        n = period / step
        if n < 1.0 - 1e-9 or abs(n - round(n)) > 1e-6:
            raise ValueError(
                f"parameter '{name}' refused: its period {period:g} s is not a whole number of "
                f"physics steps (physics_timestep = {step:g} s)"
            )


def _publish_steps(rate_hz: float, skin_every: int, dt: float) -> int:
    """Physics steps between two taxel publications: every skin sample for a rate of 0, else
    the publication period, which must be a whole number of skin periods (ValueError naming
    ``taxel_publish_rate_hz`` otherwise)."""
    if rate_hz <= 0.0:
        return skin_every
    steps = max(1, round(1.0 / (rate_hz * dt)))
    if steps % skin_every:
        raise ValueError(
            f"parameter 'taxel_publish_rate_hz' refused value {rate_hz:g}: its period must be a "
            f"whole number of skin periods ({skin_every * dt:g} s)"
        )
    return steps


def sim_config(values: dict[str, ParamValue]) -> SimConfig:
    """The simulation's configuration from the bridge's parameter values (skin model, command
    timeout [s], seed, physics step [s], plant); ValueError naming ``plant`` for an unknown
    plant."""
    plant = str(values["plant"])
    if plant not in PLANTS:
        raise ValueError(f"parameter 'plant' refused value {plant!r}: allowed "
                         f"{', '.join(PLANTS)}")
    return SimConfig(
        skin=SkinConfig(softness=float(values["skin_softness"]),
                        noise_std=float(values["skin_noise_std"]),
                        gain_error_std=float(values["skin_gain_error_std"]),
                        offset_std=float(values["skin_offset_std"]),
                        dead_taxels=int(values["skin_dead_taxels"])),
        command_timeout=float(values["command_timeout"]),
        seed=int(values["seed"]),
        timestep=float(values["physics_timestep"]),
        protective_stop=ProtectiveStopConfig(enabled=bool(values["protective_stop"])),
        plant=plant,
    )


def sensor_faults(values: dict[str, ParamValue], joint_names: tuple[str, ...]) -> SensorFaults:
    """The sensor faults of the ``fault`` and ``fault_time`` parameters; ValueError naming the
    parameter for an unknown fault."""
    fault = str(values["fault"])
    if fault and fault not in FAULT_KINDS:
        raise ValueError(f"parameter 'fault' refused value {fault!r}: allowed '' or "
                         f"{', '.join(FAULT_KINDS)}")
    spec = FaultSpec(fault, float(values["fault_time"]), patch=str(values["fault_patch"]),
                     value=float(values["fault_value"]) or math.nan) if fault else None
    return SensorFaults(spec, joint_names)


def shove_of(values: dict[str, ParamValue]) -> Shove:
    """The shove of the ``shove`` parameter; ValueError naming the parameter if malformed."""
    text = str(values["shove"])
    try:
        return Shove(ShoveSpec.parse(text) if text else None)
    except ValueError as err:
        raise ValueError(f"parameter 'shove' refused value {text!r}: {err}") from None


def _doubles(values: np.ndarray) -> array.array[float]:
    """A float64 array as the ``array('d')`` a message's float64[] field stores (the setter
    takes it as is; a list is checked element by element)."""
    out = array.array("d")
    out.frombytes(np.ascontiguousarray(values, dtype=np.float64).tobytes())
    return out


def fill_joint_state(msg: JointState, q: np.ndarray, qd: np.ndarray, stamp_ns: int,
                     effort: np.ndarray | None = None) -> None:
    """Write positions [rad] or [m], velocities [rad/s] or [m/s], efforts [N·m] or [N] (when
    given; :meth:`SimRobot.efforts <phri_sim.world.robot.SimRobot.efforts>`) and the stamp into
    a JointState whose names are set."""
    msg.header.stamp = ns_to_stamp(stamp_ns)
    msg.position = _doubles(q)
    msg.velocity = _doubles(qd)
    if effort is not None:
        msg.effort = _doubles(effort)


def joint_state_msg(names: tuple[str, ...], q: np.ndarray, qd: np.ndarray, stamp_ns: int,
                    effort: np.ndarray | None = None) -> JointState:
    """JointState of ``names`` (positions [rad] or [m], velocities [rad/s] or [m/s], efforts
    [N·m] or [N] when given)."""
    msg = JointState(name=list(names))
    fill_joint_state(msg, q, qd, stamp_ns, effort)
    return msg


def fill_odometry(msg: Odometry, q_base: np.ndarray, twist: np.ndarray, stamp_ns: int) -> None:
    """Write the planar pose (x, y, yaw) in ``odom`` and the body-frame twist of ``base_link``
    [m, rad, m/s, rad/s] and the stamp into an Odometry."""
    msg.header.stamp = ns_to_stamp(stamp_ns)
    msg.header.frame_id, msg.child_frame_id = "odom", "base_link"
    pose, vel = msg.pose.pose, msg.twist.twist
    pose.position.x, pose.position.y, pose.position.z = float(q_base[0]), float(q_base[1]), 0.0
    w, x, y, z = quaternion_from_yaw(float(q_base[2]))
    o = pose.orientation
    o.w, o.x, o.y, o.z = w, x, y, z
    vel.linear.x, vel.linear.y, vel.linear.z = float(twist[0]), float(twist[1]), 0.0
    vel.angular.x, vel.angular.y, vel.angular.z = 0.0, 0.0, float(twist[2])


def odometry_msg(q_base: np.ndarray, twist: np.ndarray, stamp_ns: int) -> Odometry:
    """Odometry: planar pose (x, y, yaw) in ``odom`` and the body-frame twist of ``base_link``."""
    msg = Odometry()
    fill_odometry(msg, q_base, twist, stamp_ns)
    return msg


def twist_to_command(msg: Twist) -> np.ndarray:
    """/cmd_vel → [v_x, v_y, ω_z] (body frame) [m/s, rad/s]."""
    return np.array([msg.linear.x, msg.linear.y, msg.angular.z], dtype=np.float64)


class SimBridgeNode(Node):
    """The simulated robot, skins and person behind the hardware topics (module docstring)."""

    def __init__(self, *, node_name: str = "phri_sim", scenario: Scenario | None = None,
                 **kwargs: Any) -> None:
        """``scenario``: the scenario to play, given as a value in-process (the lock-step
        runner: any scenario, e.g. one with another parameter set or a lead); the ``scenario``
        parameter, a name of the catalogue for launch files, must then be '' or its name."""
        super().__init__(node_name, **kwargs)
        self.viewer: Any = None
        self._given_scenario = scenario
        try:
            self._setup()
        except ValueError:
            # A refused parameter: leave no half-built node behind in the context.
            super().destroy_node()
            raise

    def _setup(self) -> None:
        self.values: dict[str, ParamValue] = declare_parameters(self, PARAMS)
        v = self.values
        self.scenario = self._scenario(str(v["scenario"]))
        config = sim_config(v)
        periods = {
            "control_period": float(v["control_period"]),
            "skin_rate_hz": 1.0 / float(v["skin_rate_hz"]),
            "state_rate_hz": 1.0 / float(v["state_rate_hz"]),
        }
        if float(v["taxel_publish_rate_hz"]) > 0.0:
            periods["taxel_publish_rate_hz"] = 1.0 / float(v["taxel_publish_rate_hz"])
        if float(v["ground_truth_rate_hz"]) > 0.0:
            periods["ground_truth_rate_hz"] = 1.0 / float(v["ground_truth_rate_hz"])
        _check_divides(float(v["physics_timestep"]), periods)
        self.sim = Simulation(config)
        self.script: Script | None = None
        if self.scenario is not None:
            self.script = start_scenario(self.sim, self.scenario)
        else:
            self.sim.reset(np.array(Q_HOME))
        self.faults = sensor_faults(v, self.sim.joint_names[3:])
        self.shove = shove_of(v)
        self.period = float(v["control_period"])
        self.steps_per_period = max(1, round(self.period / self.sim.dt))
        self._skin_every = max(1, round(1.0 / (float(v["skin_rate_hz"]) * self.sim.dt)))
        self._publish_every = _publish_steps(float(v["taxel_publish_rate_hz"]), self._skin_every,
                                             self.sim.dt)
        self.skin_link: SkinLink | None = None
        if bool(v["skin_driver"]):
            self.skin_link = SkinLink(self.sim.skins.sensors)
            self.skin_link.tare(self._skin_every * self.sim.dt)
        self.pipeline: DriverPipeline | None = None
        """The driver's moving average on the realistic plant without the driver in the loop
        (:mod:`phri_sim.world.skin_pipeline`)."""
        if self.skin_link is None and self.sim.plant.skin_pipeline:
            self.pipeline = DriverPipeline(self._skin_every * self.sim.dt,
                                           tuple(self.sim.patches))
        self._readings: dict[str, np.ndarray] = {}
        self._taxel_listeners: list[TaxelListener] = []
        self._state_listeners: list[tuple[JointStateListener, OdometryListener]] = []
        self._idle_every = int(v["skin_idle_decimation"])
        self._idle_count = dict.fromkeys(self.sim.patches, 0)
        self._was_touched = dict.fromkeys(self.sim.patches, True)
        self.published_patches: list[str] = []
        self._state_every = max(1, round(1.0 / (float(v["state_rate_hz"]) * self.sim.dt)))
        gt_rate = float(v["ground_truth_rate_hz"])
        self._truth_every = 0 if gt_rate <= 0 else max(1, round(1.0 / (gt_rate * self.sim.dt)))
        self.step_count = 0
        self._effort_sum = np.zeros(len(self.sim.joint_names))
        self._effort_steps = 0
        self.commands_received = dict.fromkeys(("base", "left", "right"), 0)
        self.commands_refused = 0

        self._make_topics()
        if bool(v["viewer"]):
            self._open_viewer()
        self.timer = None
        if not bool(v["lockstep"]):
            wall = self.period / float(v["real_time_factor"])
            self.timer = self.create_timer(wall, self._tick)
        self.publish_all(clock=True)

    def _scenario(self, name: str) -> Scenario | None:
        """The scenario to play: the one given to the constructor, else the catalogue's
        scenario ``name`` ('' = none: person parked, robot at home); ValueError naming the
        ``scenario`` parameter otherwise."""
        given = self._given_scenario
        if given is not None:
            if name not in ("", given.name):
                raise ValueError(f"parameter 'scenario' refused value {name!r}: the node was "
                                 f"given scenario {given.name!r}")
            return given
        if name and name not in SCENARIOS:
            raise ValueError(
                f"parameter 'scenario' refused value {name!r}: allowed '' or "
                f"{', '.join(SCENARIOS)}"
            )
        return SCENARIOS.get(name)

    def _make_topics(self) -> None:
        """Encoders, publishers and command subscriptions (docs/phri_sim.md, Topics)."""
        self.encoders = {
            name: TaxelCloudEncoder(p.layout.positions, p.layout.normals, p.layout.link)
            for name, p in self.sim.patches.items()
        }
        self.skin_pubs = {
            name: self.create_publisher(PointCloud2, f"skin/{name}/taxels", SENSOR_QOS)
            for name in self.sim.patches
        }
        self.joint_pub = self.create_publisher(JointState, "/joint_states", SENSOR_QOS)
        self._joint_msg = JointState(name=list(self.sim.joint_names))
        self._odom_msg = Odometry()
        self.odom_pub = self.create_publisher(Odometry, "/odom", SENSOR_QOS)
        self.clock_pub = self.create_publisher(Clock, "/clock", 10)
        self._clock_msg = Clock()
        self.wrench_pubs = {
            link: self.create_publisher(WrenchStamped, f"sim/contacts/{link}/wrench", 10)
            for link in self.sim.skin_links
        }
        self.center_pubs = {
            link: self.create_publisher(PointStamped, f"sim/contacts/{link}/center", 10)
            for link in self.sim.skin_links
        }
        self.person_pub = self.create_publisher(PoseArray, "sim/person/poses", 10)
        self.diag_pub = self.create_publisher(DiagnosticArray, "/diagnostics", 10)
        self._arm_phases: dict[str, str] = {}
        self._diag_due = 0.0
        for side in ARM_TOPICS:
            self.create_service(Trigger, f"sim/{side}/unlock_protective_stop",
                                self._unlock_service(side))
        self.create_subscription(Twist, "/cmd_vel", self._on_cmd_vel, 10)
        for side, topic in ARM_TOPICS.items():
            self.create_subscription(
                Float64MultiArray, topic, lambda msg, side=side: self._on_arm(side, msg), 10
            )

    # -- commands -------------------------------------------------------------------------------
    def _command(self, channel: str, values: np.ndarray) -> None:
        try:
            self.sim.command(channel, values)
            self.commands_received[channel] += 1
        except CommandError as err:
            self.commands_refused += 1
            self.get_logger().warning(f"refused command: {err}; {channel} stopped",
                                      throttle_duration_sec=1.0)

    def _on_cmd_vel(self, msg: Twist) -> None:
        self._command("base", twist_to_command(msg))

    def _on_arm(self, side: str, msg: Float64MultiArray) -> None:
        self._command(side, np.asarray(msg.data, dtype=np.float64))

    # -- stepping -------------------------------------------------------------------------------
    @property
    def stamp_ns(self) -> int:
        """Simulation time [ns] (integer steps × dt, so stamps are exact)."""
        return round(self.step_count * self.sim.dt * 1e9)

    @property
    def fault_clock(self) -> float:
        """Sim time [s] the sensor faults see: the exact stamp of the outgoing messages."""
        return self.stamp_ns * 1e-9

    def advance(self, periods: int = 1, *, clock: bool = True) -> None:
        """Advance ``periods`` control periods, publishing each topic when it falls due; publish
        /clock at the end unless ``clock`` is False (lock-step publishes it after the sensors
        have been consumed)."""
        for _ in range(periods):
            for _ in period_steps(self.sim, self.script, self.shove, self.steps_per_period):
                self._after_physics_step()
        self.publish_arm_status()
        if clock:
            self.publish_clock()
        if self.viewer is not None:
            self.viewer.sync()

    def _after_physics_step(self) -> None:
        """The drives' efforts, and the skin, ground truth and state when they fall due."""
        self._effort_sum += self.sim.robot.efforts()
        self._effort_steps += 1
        self.step_count += 1
        n = self.step_count
        if n % self._skin_every == 0:
            self.sample_skin(publish=n % self._publish_every == 0)
        if self._truth_every and n % self._truth_every == 0:
            self.publish_ground_truth()
        if n % self._state_every == 0:
            self.publish_state()

    def _tick(self) -> None:
        self.advance()

    # -- the arms' protective stops ---------------------------------------------------------------
    def publish_arm_status(self, force: bool = False) -> None:
        """Each arm's state on /diagnostics (:mod:`phri_sim.ros.arm_status`) at once when an
        arm's protective-stop phase changed, else once per simulated second."""
        stop = self.sim.robot.protective_stop
        statuses = {side: stop.status(side) for side in ARM_TOPICS}
        phases = {side: st.phase for side, st in statuses.items()}
        now = self.sim.time
        if not force and phases == self._arm_phases and now < self._diag_due:
            return
        self._arm_phases, self._diag_due = phases, now + 1.0
        rearm = stop.config.rearm_velocity
        msg = DiagnosticArray(status=[arm_status(side, st, rearm)
                                      for side, st in statuses.items()])
        msg.header.stamp = ns_to_stamp(self.stamp_ns)
        self.diag_pub.publish(msg)

    def _unlock_service(self, side: str) -> Callable[[Trigger.Request, Trigger.Response],
                                                     Trigger.Response]:
        return lambda _req, res: self._unlock(side, res)

    def _unlock(self, side: str, res: Trigger.Response) -> Trigger.Response:
        """``sim/<arm>/unlock_protective_stop``: the operator's unlock (refused within 5 s)."""
        res.success, res.message = self.sim.robot.protective_stop.unlock(side)
        self.publish_arm_status(force=True)
        return res

    # -- publishing -----------------------------------------------------------------------------
    def publish_all(self, clock: bool) -> None:
        """Every topic once at the current state."""
        self.publish_state()
        self.publish_skin(force=True)
        self.publish_ground_truth()
        if clock:
            self.publish_clock()

    def publish_clock(self) -> None:
        """/clock at the simulation time."""
        self._clock_msg.clock = ns_to_stamp(self.stamp_ns)
        self.clock_pub.publish(self._clock_msg)

    def publish_state(self) -> None:
        """/joint_states (the base joints base_x, base_y, base_yaw, so robot_state_publisher
        connects odom → base_link, then the 12 arm joints through the sensor faults) and /odom."""
        stamp = self.stamp_ns
        q, qd = self.sim.q, self.sim.qd
        positions = np.concatenate([q[:3], self.faults.joints(q[3:], self.fault_clock)])
        # One message of each, refilled: publish() serialises it at once.
        joints, odom = self._joint_msg, self._odom_msg
        fill_joint_state(joints, positions, qd, stamp, self._mean_efforts())
        fill_odometry(odom, q[:3], self.sim.base_twist(), stamp)
        for on_joints, on_odom in self._state_listeners:
            on_joints(joints)
            on_odom(odom)
        direct = bool(self._state_listeners)
        if not direct or self.joint_pub.get_subscription_count() > 0:
            self.joint_pub.publish(joints)
        if not direct or self.odom_pub.get_subscription_count() > 0:
            self.odom_pub.publish(odom)

    def _mean_efforts(self) -> np.ndarray:
        """The drives' efforts averaged over the physics steps since the last joint state (a
        drive's current is filtered, not sampled; the mean force over a state period is what
        the change of velocity over it needs, so a reader differencing velocities finds the
        two consistent); the present ones before the first step [N, N·m]."""
        if self._effort_steps == 0:
            return self.sim.robot.efforts()
        mean = self._effort_sum / self._effort_steps
        self._effort_sum = np.zeros_like(self._effort_sum)
        self._effort_steps = 0
        return mean

    def sample_skin(self, *, publish: bool = True) -> None:
        """One skin sample of every patch due (below); publish the newest reading of each
        patch sampled since the last publication when ``publish``.

        With the driver in the loop, or its pipeline modelled (:attr:`pipeline`), every sample
        goes through it (its moving average needs them all); otherwise a sample that is not
        published is not computed (nothing would see it). With ``skin_idle_decimation`` N > 1 a
        patch nobody touches (and that was untouched in its last sample, and whose modelled
        pipeline holds no force) is read only once N samples have passed since its last
        reading (so every N skin periods, driver or not).
        """
        for name in self._idle_count:
            self._idle_count[name] += 1
        pipeline = self.pipeline
        if self.skin_link is None and pipeline is None and not publish:
            return
        every = self._idle_every
        due: dict[str, np.ndarray] = {}
        for name, clean in self.sim.clean_skin_forces().items():
            touched = bool(np.any(clean > 0.0)) or (pipeline is not None
                                                   and pipeline.holding(name))
            if every <= 1 or touched or self._was_touched[name] or self._idle_count[name] >= every:
                self._idle_count[name] = 0
                self._was_touched[name] = touched
                due[name] = clean
        self._read(due)
        if publish:
            self._publish_readings()

    def _read(self, clean: dict[str, np.ndarray]) -> None:
        """Readings [N] of the patches in ``clean`` (true forces) through the sensor model and,
        when in the loop, the skin driver, kept until published."""
        if self.skin_link is None:
            if self.pipeline is not None:
                clean = self.pipeline.push(clean)
            for name, forces in clean.items():
                self._readings[name] = self.sim.skin_reading(name, forces)
            return
        self._readings.update(self.skin_link.send(clean, self.stamp_ns * 1e-9))

    def publish_skin(self, *, force: bool = False) -> None:
        """Publish the skin now: every patch sampled at the current state with ``force`` (not
        counted as a sample of the idle schedule: the first scheduled sample after it still
        carries every patch, for subscribers that joined late), else one scheduled sample."""
        if not force:
            self.sample_skin(publish=True)
            return
        clean = self.sim.clean_skin_forces()
        if self.pipeline is not None:
            self.pipeline.prime(clean)  # the state so far has lasted: a settled hold reads it
        self._read(clean)
        self._publish_readings()

    def add_taxel_listener(self, listener: TaxelListener) -> None:
        """Hand every taxel array to ``listener(patch, taxels)`` in this process, e.g. contact
        estimation's ``on_frame`` (the lock-step runner): the taxels exactly as a subscriber
        decodes the message (its float32 columns, :meth:`TaxelCloudEncoder.taxels`), without
        the message, its serialisation and the DDS round trip. From then on the taxel topics go
        out only while they have subscribers (a recorder), like the ground truth."""
        self._taxel_listeners.append(listener)

    def add_state_listener(self, on_joints: JointStateListener, on_odom: OdometryListener
                           ) -> None:
        """Hand every /joint_states and /odom message to ``on_joints`` / ``on_odom`` in this
        process (the controller's callbacks, lock-step runner): the message the topic would
        carry, without its serialisation and the DDS round trip (it is refilled for the next
        state: a listener copies what it keeps). From then on the two topics go out only while
        they have subscribers."""
        self._state_listeners.append((on_joints, on_odom))

    def _publish_readings(self) -> None:
        """One taxel array per patch with a reading since the last publication (frame = the
        patch's link), through the sensor faults, to the listeners and the topic;
        :attr:`published_patches` lists them."""
        stamp = self.stamp_ns
        self.published_patches = []
        for name, reading in self._readings.items():
            forces = self.faults.taxels(name, reading, self.fault_clock)
            encoder = self.encoders[name]
            if self._taxel_listeners:
                taxels = encoder.taxels(forces, stamp)
                for listener in self._taxel_listeners:
                    listener(name, taxels)
            if not self._taxel_listeners or self.skin_pubs[name].get_subscription_count() > 0:
                self.skin_pubs[name].publish(encoder.encode(forces, stamp))
            self.published_patches.append(name)
        self._readings = {}

    def publish_ground_truth(self) -> None:
        """True force on each skin link (link frame; zero when untouched), its centre (only
        while touched) and the person's poses (odom). Topics nobody subscribes to are skipped:
        ground truth is for evaluation and recording, and seven unread messages per period
        cost the lock-step runner about a third of its time."""
        pubs = (*self.wrench_pubs.values(), *self.center_pubs.values(), self.person_pub)
        if not any(pub.get_subscription_count() > 0 for pub in pubs):
            return
        # Serialized here (phri_common.cdr): building the messages' Python objects cost more
        # than the rest of publishing them.
        stamp = self.stamp_ns
        for link, gt in self.sim.ground_truth().items():
            if self.wrench_pubs[link].get_subscription_count() > 0:
                self.wrench_pubs[link].publish(
                    wrench_stamped_to_cdr(stamp, link, gt.force_link.tolist()))
            if gt.in_contact and self.center_pubs[link].get_subscription_count() > 0:
                self.center_pubs[link].publish(
                    point_stamped_to_cdr(stamp, link, gt.center_link.tolist()))
        if self.person_pub.get_subscription_count() == 0:
            return
        poses = []
        for part in self.sim.parts:
            pos, quat = self.sim.part_pose(part.name)  # quat: w, x, y, z
            poses.append((*pos.tolist(), *quat[1:4].tolist(), float(quat[0])))
        self.person_pub.publish(pose_array_to_cdr(stamp, "odom", poses))

    # -- viewer ---------------------------------------------------------------------------------
    def _open_viewer(self) -> None:
        import os

        if not os.environ.get("DISPLAY") and not os.environ.get("WAYLAND_DISPLAY"):
            self.get_logger().warning("viewer requested but no display: running headless")
            return
        import mujoco.viewer

        self.viewer = mujoco.viewer.launch_passive(self.sim.model, self.sim.data)

    def destroy_node(self) -> None:
        """Close the viewer, then tear down."""
        if self.viewer is not None:
            self.viewer.close()
            self.viewer = None
        super().destroy_node()


def main(args: list[str] | None = None) -> None:
    """Entry point ``phri_sim_bridge``: the free-running simulation until Ctrl-C / SIGTERM.

    Runs under :func:`phri_common.ros_main.run_nodes`, whose signal handlers only set a stop flag:
    with rclpy's default handler, SIGINT invalidated the context while a timer tick was still
    publishing, and the bridge died with ``RCLError: Failed to publish: publisher's context is
    invalid`` (most launches stopped with Ctrl-C, measured; test_bridge.py checks the exit)."""
    sys.exit(run_nodes(lambda: [SimBridgeNode()], "phri_sim", args))
