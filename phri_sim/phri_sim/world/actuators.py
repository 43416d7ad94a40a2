"""The robot's drives as hardware has them: what the simulated servos are told (pure, no rclpy).

The commands the watchdog passes on (:mod:`phri_sim.world.command_watchdog`: body twist of the
base [m/s, rad/s], 12 arm joint velocities [rad/s]) are what the controller *asked*; a real
robot's drives do not execute them at once. :class:`CommandShaper` turns them into the set points
the simulated velocity servos follow, as the hardware would (docs/phri_sim.md, "Plant"):

* **mecanum base** (:class:`BaseDrive`), per body-twist axis (v_x, v_y, ω_z), in this order:

  1. command latency L_b: the command in force at t acts from t + L_b (the base controller's
     sampling and the bus);
  2. an acceleration- and jerk-limited ramp (the base controller's velocity profile): the set
     point r moves towards the command with acceleration |a| ≤ A and jerk |ȧ| ≤ J, braking its
     acceleration in time so that it does not overshoot a still command (|a| ≤ √(2 J |e|),
     e = command − r, in its exact form per tick);
  3. a first-order velocity-loop lag τ_b (the wheels' velocity loops with the platform's mass):
     v̇ = (r − v) / τ_b, integrated exactly per tick.

* **UR16e arms** (:class:`ArmDrive`), ur_rtde's ``speedJ`` on the 500 Hz RTDE cycle: the
  controller reads the newest command at each cycle boundary and executes it one cycle later
  (latency one cycle); ``speedJ(qd, a)`` ramps the joint speeds towards qd with the acceleration
  a of the leading axis, the other joints scaled to arrive at the same time; the set point is
  held over each cycle.

Time runs on an integer grid of ticks (1 ms, or the physics step when that is shorter), so the
latencies are exact; each physics step's servo set point is the mean of its ticks' outputs.
:data:`PLANTS` names the two plants of ``--plant``: ``realistic`` (the default; the drives above
and the skin's driver pipeline, :mod:`phri_sim.world.skin_pipeline`) and ``ideal`` (the servos
follow every command at once, as before the realistic plant: 2·10⁴ N·s/m capped at 3 kN).
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]

TICK = 0.001
"""Time grid of the drive models [s] (the physics step when that is shorter)."""


def _check_non_negative(name: str, value: float) -> None:
    if not (math.isfinite(value) and value >= 0.0):
        raise ValueError(f"{name} must be a finite value >= 0 [s], got {value}")


@dataclass(frozen=True)
class BaseDrive:
    """The mecanum base's drive (module docstring), per body-twist axis (v_x, v_y, ω_z).

    Attributes:
        latency: command latency L_b [s].
        lag: velocity-loop time constant τ_b [s] (0 = none).
        acceleration: rated accelerations A [m/s², m/s², rad/s²].
        jerk: jerk limits J [m/s³, m/s³, rad/s³].
    """

    latency: float = 0.020
    lag: float = 0.030
    acceleration: tuple[float, float, float] = (1.0, 1.0, 1.5)
    jerk: tuple[float, float, float] = (50.0, 50.0, 75.0)

    def __post_init__(self) -> None:
        _check_non_negative("base latency", self.latency)
        _check_non_negative("base lag", self.lag)
        for name in ("acceleration", "jerk"):
            values = getattr(self, name)
            if len(values) != 3 or not all(math.isfinite(v) and v > 0.0 for v in values):
                raise ValueError(f"base {name} must be 3 finite values > 0, got {values}")


@dataclass(frozen=True)
class ArmDrive:
    """The UR16e's ``speedJ`` on the RTDE cycle (module docstring).

    Attributes:
        cycle: RTDE control cycle [s] (500 Hz).
        latency_cycles: cycles between reading a command and executing it.
        acceleration: speedJ's acceleration of the leading axis [rad/s²] (the bridge's, 2.0).
    """

    cycle: float = 0.002
    latency_cycles: int = 1
    acceleration: float = 2.0

    def __post_init__(self) -> None:
        if not (math.isfinite(self.cycle) and self.cycle > 0.0):
            raise ValueError(f"RTDE cycle must be > 0 [s], got {self.cycle}")
        if self.latency_cycles < 0:
            raise ValueError(f"RTDE latency must be >= 0 cycles, got {self.latency_cycles}")
        if not (math.isfinite(self.acceleration) and self.acceleration > 0.0):
            raise ValueError(f"speedJ acceleration must be > 0 [rad/s²], got "
                             f"{self.acceleration}")


@dataclass(frozen=True)
class Plant:
    """What stands between the controller's commands and the simulated robot.

    Attributes:
        name: ``realistic`` or ``ideal``.
        base: the base's drive; ``None`` = the servos follow the command at once.
        arm: the arms' RTDE drive; ``None`` = at once.
        skin_pipeline: the taxel arrays reach contact estimation through the skin driver's
            500 Hz moving average (:mod:`phri_sim.world.skin_pipeline`); off: the newest sample.
    """

    name: str
    base: BaseDrive | None = field(default_factory=BaseDrive)
    arm: ArmDrive | None = field(default_factory=ArmDrive)
    skin_pipeline: bool = True

    @property
    def shapes_commands(self) -> bool:
        """Whether a drive model stands between command and servo."""
        return self.base is not None or self.arm is not None


PLANTS: dict[str, Plant] = {
    "realistic": Plant("realistic"),
    "ideal": Plant("ideal", base=None, arm=None, skin_pipeline=False),
}
"""The plants of ``--plant`` (docs/phri_sim.md, "Plant")."""
DEFAULT_PLANT = "ideal"
"""The plant of ``phri sim`` and the bridge unless told: ``ideal`` while the whole-body
controller does not yet hold the waltz's partner on the ``realistic`` one (docs/phri_sim.md,
"Plant": the measurement); the tempo ladder runs on ``realistic``."""


def plant_named(name: str) -> Plant:
    """The plant ``name`` of :data:`PLANTS`; ValueError naming the known ones otherwise."""
    if name not in PLANTS:
        raise ValueError(f"plant {name!r} unknown: allowed {', '.join(PLANTS)}")
    return PLANTS[name]


def _ticks(duration: float, tick: float, what: str) -> int:
    """``duration`` [s] as a whole number of ``tick`` [s]; ValueError naming ``what`` if not."""
    n = duration / tick
    if abs(n - round(n)) > 1e-6:
        raise ValueError(f"{what} {duration:g} s is not a whole number of drive ticks "
                         f"({tick:g} s)")
    return round(n)


def drive_tick(dt: float) -> float:
    """The drive models' tick for a physics step ``dt`` [s]: :data:`TICK` when it divides the
    step, the step itself when the step divides :data:`TICK`; ValueError otherwise."""
    if dt >= TICK and abs(dt / TICK - round(dt / TICK)) < 1e-6:
        return TICK
    if dt < TICK and abs(TICK / dt - round(TICK / dt)) < 1e-6:
        return dt
    raise ValueError(f"physics step {dt:g} s: the drive models need a multiple or a whole "
                     f"fraction of {TICK:g} s")


class JerkLimitedRamp:
    """Set points that follow a target with bounded acceleration and jerk (module docstring,
    base step 2), one per axis (plain floats: a few axes per tick, where numpy's per-call cost
    would dominate).

    Args:
        acceleration: A per axis [unit/s²] (> 0).
        jerk: J per axis [unit/s³] (> 0).
    """

    def __init__(self, acceleration: tuple[float, ...], jerk: tuple[float, ...]) -> None:
        self.a_max = [float(a) for a in acceleration]
        self.j_max = [float(j) for j in jerk]
        self.value = [0.0] * len(self.a_max)
        self.accel = [0.0] * len(self.a_max)

    def reset(self) -> None:
        """At rest: values and accelerations zero."""
        self.value = [0.0] * len(self.a_max)
        self.accel = [0.0] * len(self.a_max)

    def step(self, target: list[float], h: float) -> list[float]:
        """Advance ``h`` [s] towards ``target`` (one value per axis); returns the new values
        (the ramp's own list)."""
        for i, goal in enumerate(target):
            v, a, j = self.value[i], self.accel[i], self.j_max[i]
            error = goal - v
            # The largest acceleration from which braking at the jerk limit, tick by tick,
            # ends on the target: a·h + a²/(2J) − a·h/2 ≤ |e|.
            brake = j * (math.sqrt(0.25 * h * h + 2.0 * abs(error) / j) - 0.5 * h)
            wanted = math.copysign(min(self.a_max[i], brake), error)
            dj = j * h
            settled = abs(a) <= dj  # its acceleration can end this tick within the jerk limit
            a += min(max(wanted - a, -dj), dj)
            v += a * h
            if settled and abs(goal - v) <= dj * h:
                v, a = goal, 0.0  # on the target within a tick's worth of jerk: no chattering
            self.value[i], self.accel[i] = v, a
        return self.value


class _BaseModel:
    """The base's latency, ramp and lag on the tick grid (plain floats)."""

    def __init__(self, drive: BaseDrive, tick: float) -> None:
        self.delay = _ticks(drive.latency, tick, "base latency")
        self.ramp = JerkLimitedRamp(drive.acceleration, drive.jerk)
        self.alpha = 1.0 if drive.lag <= 0.0 else 1.0 - math.exp(-tick / drive.lag)
        self.tick = tick
        self.inputs: deque[tuple[int, list[float]]] = deque()
        self.output = [0.0, 0.0, 0.0]

    def reset(self) -> None:
        self.ramp.reset()
        self.inputs.clear()
        self.output = [0.0, 0.0, 0.0]

    def receive(self, k: int, u: list[float]) -> None:
        """The command ``u`` (3) in force from tick ``k`` on."""
        if not self.inputs or self.inputs[-1][1] != u:
            self.inputs.append((k, u))

    def mean_over(self, k: int, n: int) -> list[float]:
        """Outputs at ticks k … k + n − 1 (called for consecutive ticks), averaged."""
        total = [0.0, 0.0, 0.0]
        inputs, ramp, alpha, out = self.inputs, self.ramp, self.alpha, self.output
        for tick in range(k, k + n):
            due = tick - self.delay
            while len(inputs) > 1 and inputs[1][0] <= due:
                inputs.popleft()
            target = inputs[0][1] if inputs and inputs[0][0] <= due else [0.0, 0.0, 0.0]
            r = ramp.step(target, self.tick)
            for i in range(3):
                out[i] += alpha * (r[i] - out[i])
                total[i] += out[i]
        return [x / n for x in total]


class _ArmModel:
    """speedJ on the RTDE cycle, both arms (12 joints; the leading axis per arm)."""

    def __init__(self, drive: ArmDrive, tick: float) -> None:
        self.cycle = _ticks(drive.cycle, tick, "RTDE cycle")
        self.latency = drive.latency_cycles
        self.step_size = drive.acceleration * drive.cycle
        self.pending: deque[list[float]] = deque()
        self.output = [0.0] * 12

    def reset(self) -> None:
        self.pending.clear()
        self.output = [0.0] * 12

    def _cycle(self, latest: list[float]) -> None:
        """A cycle boundary: read ``latest``, execute the command read ``latency`` cycles ago
        with speedJ's ramp over one cycle (the leading axis of each arm at the acceleration)."""
        self.pending.append(latest)
        if len(self.pending) <= self.latency:
            return
        target, out, step = self.pending.popleft(), self.output, self.step_size
        for lo in (0, 6):
            delta = [target[i] - out[i] for i in range(lo, lo + 6)]
            lead = max(abs(d) for d in delta)
            scale = 1.0 if lead <= step else step / lead
            for i in range(6):
                out[lo + i] += delta[i] * scale

    def mean_over(self, k: int, n: int, latest: list[float]) -> list[float]:
        """Set points at ticks k … k + n − 1 with ``latest`` the command in force, averaged."""
        total = [0.0] * 12
        for tick in range(k, k + n):
            if tick % self.cycle == 0:
                self._cycle(latest)
            for i, v in enumerate(self.output):
                total[i] += v
        return [x / n for x in total]


class CommandShaper:
    """The plant's drives between the watchdog's command and the servos (module docstring).

    Args:
        plant: the drives (a plant without any passes commands through).
        dt: physics step [s] (a multiple or whole fraction of :data:`TICK`).
    """

    def __init__(self, plant: Plant, dt: float) -> None:
        self.plant = plant
        self.tick = drive_tick(dt)
        self.per_step = max(1, round(dt / self.tick))
        self._base = None if plant.base is None else _BaseModel(plant.base, self.tick)
        self._arm = None if plant.arm is None else _ArmModel(plant.arm, self.tick)
        self._k = 0

    def reset(self) -> None:
        """Every drive at rest, no command received, the tick count at 0 (sim time 0)."""
        self._k = 0
        for model in (self._base, self._arm):
            if model is not None:
                model.reset()

    def __call__(self, u: FloatArray) -> FloatArray:
        """The 15 servo set points for the next physics step given the 15 commands ``u`` in
        force over it (body twist [m/s, rad/s], then the arms [rad/s]): the mean over the step's
        ticks of each drive's output; a new array."""
        values = [float(x) for x in u]
        base, arm, k, n = self._base, self._arm, self._k, self.per_step
        if base is not None:
            base.receive(k, values[:3])
            values[:3] = base.mean_over(k, n)
        if arm is not None:
            values[3:] = arm.mean_over(k, n, values[3:])
        self._k += n
        return np.array(values)
