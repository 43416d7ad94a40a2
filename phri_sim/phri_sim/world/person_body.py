"""The simulated person: compliant body parts held by spring–dampers to scripted targets (pure).

Each body part is a free rigid body in the MuJoCo scene (gravity compensated, as a person holds
their own weight). Every physics step it receives the wrench of a 6-D spring–damper pulling it
towards its scripted target pose::

    F = K_lin (p_target − p) + D_lin (v_target − v)                 [N]
    τ = K_rot log(R_target Rᵀ)^∨ + D_rot (0 − ω)                   [N·m]

so the force the part exerts on the robot comes from contact physics: a hand whose target lies
δ inside a link presses with ≈ K_lin·δ while the link stands still, and the force falls as the
robot yields (moves away from the target).

Soft tissue. A rigid 30 kg torso against a velocity-servoed robot makes a stiff, bouncy contact:
MuJoCo's contact stiffness scales with the effective mass, and an impact at a few cm/s gives
tens of newtons in one control period, which the admittance (D = 200 N·s/m) answers by backing off
at the speed limit. A person's waist is soft: flesh and clothes over the trunk give a few kN/m
with strong tissue damping. :class:`SoftTissue` models that explicitly: the waist geom rides on a
light body (``<part>_tissue``) joined to the torso by two horizontal slide joints (torso frame x
and y) with a spring K_t [N/m] and a damper D_t [N·s/m], so the waist contact behaves as a
known linear compliance (10 N compresses it by 10 / K_t) whatever the robot's effective mass.
The damper is set at or above critical damping for the layer's mass, so the layer does not ring.

Parts (names are the MuJoCo body names; geoms are ``<part>`` and, for the torso, ``person_waist``,
``person_abdomen``, ``person_chest`` and ``person_head``):

* ``person_torso``: the dancer's torso. Body frame: x the facing direction, y to the dancer's
  left, z up (the torso's yaw is the dancer's heading). The waist (what the robot's left forearm
  holds in the waltz) is a horizontal capsule along y — a stadium cross-section
  :data:`WAIST_WIDTH` × :data:`WAIST_DEPTH` (0.30 × 0.20 m) whose flat back lies along the
  forearm, so a turn of the dancer against the forearm shifts the pressure to one end of the
  back (the lead a round waist cannot give); above it the abdomen (horizontal capsule, its back
  3 cm in front of the waist's), a chest (horizontal capsule, 0.36 × 0.22 m) and a head (sphere).
  The abdomen fills what would otherwise be a 19 cm gap between waist and chest: without it a
  robot wrist or upper arm the partner walked into entered the gap and was squeezed between the
  waist and the chest capsules of the one rigid body, the solver pushing both out of the link —
  4–12 kN of contact force on a motionless robot in the `tempo` waltz, a hole no person has.
  It is massless (collision only), so the torso's mass and inertia are what they were.
A person who stops pushing. The spring–damper alone is a partner who never notices a robot
that has stopped: with the target dancing on, K_lin·(p_target − p) grows without bound (a 30 s
skin fault in the 186.5 s waltz, robot stopped: 128 N held on the waist; the `tempo` partner
running into the stopped robot: 18.8 kN). A person leading a dance uses tens of newtons (the
waltz's own waist force peaks at 31 N) and does not walk through a partner who has stopped, so
the torso's horizontal drive force is capped at ``max_push`` = 80 N (the direction kept):
never reached while the robot follows, and below the abdomen's quasi-static 110 N of ISO/TS
15066, so a fault scenario measures what the robot does, not a scripted push no person makes.

* ``person_left_hand``, ``person_right_hand``: spheres that press and slide on the skin.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]

PartShape = Literal["sphere", "capsule"]
Axis = Literal["x", "y", "z"]


@dataclass(frozen=True)
class GeomSpec:
    """One geom of a body part, in the part's body frame.

    Attributes:
        name: MuJoCo geom name.
        shape: ``sphere`` (size = (radius,)) or ``capsule`` (size = (radius, half length), along
            ``axis``).
        size: see ``shape`` [m].
        pos: centre in the body frame [m].
        rgba: display colour.
        axis: the body axis a capsule lies along.
        massless: the geom only collides; the part's mass is spread over its other geoms.
    """

    name: str
    shape: PartShape
    size: tuple[float, ...]
    pos: tuple[float, float, float] = (0.0, 0.0, 0.0)
    rgba: tuple[float, float, float, float] = (0.85, 0.65, 0.55, 1.0)
    axis: Axis = "z"
    massless: bool = False


@dataclass(frozen=True)
class SoftTissue:
    """A compliant layer under some of a part's geoms (module docstring, "Soft tissue").

    Attributes:
        geoms: names of the part's geoms that ride on the layer.
        mass: mass of the layer [kg].
        stiffness: K_t of each horizontal slide joint [N/m].
        damping: D_t of each slide joint [N·s/m].
        travel: range of each slide joint, ± [m] (how far the tissue can be compressed).
        yaw_stiffness: K_ψ of a hinge about the part's z axis under the layer [N·m/rad]
            (``0`` = no hinge): the layer's geoms can twist against the body, as a waist's flesh
            and clothes let a flat back conform to an arm laid across it.
        yaw_damping: D_ψ of that hinge [N·m·s/rad].
        yaw_travel: range of the hinge, ± [rad].
    """

    geoms: tuple[str, ...]
    mass: float
    stiffness: float
    damping: float
    travel: float = 0.03
    yaw_stiffness: float = 0.0
    yaw_damping: float = 0.0
    yaw_travel: float = 0.35


@dataclass(frozen=True)
class BodyPartSpec:
    """A compliant body part of the person.

    Attributes:
        name: MuJoCo body name.
        geoms: its collision geometry.
        mass: [kg].
        stiffness: translational spring K_lin [N/m].
        damping: translational damper D_lin [N·s/m].
        rot_stiffness: rotational spring K_rot [N·m/rad].
        rot_damping: rotational damper D_rot [N·m·s/rad].
        parking: where the part waits when a scenario does not use it (world) [m].
        tissue: optional compliant layer under some geoms (``None`` = all geoms rigid).
        max_push: largest horizontal drive force [N] (module docstring, "A person who stops
            pushing"); ``inf`` = the spring–damper unbounded.
    """

    name: str
    geoms: tuple[GeomSpec, ...]
    mass: float
    stiffness: float
    damping: float
    rot_stiffness: float
    rot_damping: float
    parking: tuple[float, float, float]
    tissue: SoftTissue | None = None
    max_push: float = math.inf

    @property
    def tissue_body(self) -> str:
        """MuJoCo name of the tissue layer's body."""
        return self.name + "_tissue"


HAND_RADIUS = 0.045
"""Radius of a hand (palm-sized sphere) [m]."""
WAIST_WIDTH = 0.30
"""Width of the waist, the dancer's left to right [m]."""
WAIST_DEPTH = 0.20
"""Depth of the waist, front to back [m]."""
WAIST_RADIUS = 0.5 * WAIST_DEPTH
"""Radius of the waist capsule: half the depth, the distance from the waist's centre plane to
its back [m]."""
WAIST_HALF_LENGTH = 0.5 * (WAIST_WIDTH - WAIST_DEPTH)
"""Half length of the waist capsule's segment: half the flat part of the back [m]."""
WAIST_HEIGHT = 1.00
"""Height of the waist centre above the floor when the torso stands at its target [m]."""
WAIST_TISSUE = SoftTissue(
    geoms=("person_waist",),
    mass=1.0,
    stiffness=2500.0,
    damping=120.0,
    yaw_stiffness=20.0,
    yaw_damping=2.0,
)
"""The waist's soft tissue: 2.5 kN/m (a clothed waist; soft-tissue stiffness of the trunk is of
the order of 1–5 kN/m), 1 kg of tissue, damping ratio 1.2. The damper stays well below the
admittance damping D = 200 N·s/m of the waltz, so a force step is not reflected back into the
robot's one-period-delayed command as an oscillation.

The layer also twists about the vertical, K_ψ = 20 N·m/rad, D_ψ = 2 N·m·s/rad (above critical
for the layer's ≈ 0.01 kg·m²): a waist's flesh and clothes let the flat back conform to an arm
laid across it. Measured (the skin's own pressure moment about its footprint's middle, the lead
of :mod:`wholebody_controller.following`, against the dancer's turn on a held forearm): without
the twist the lead is there from 1° but fades past 9° (the back rocks onto one end, whose
footprint is centred on itself), and the waltz lost the contact in the first turn (waist force in
band 1 %); K_ψ = 3 conforms the first 8° away (no lead below, 10–13° heading lag in the waltz);
K_ψ = 10 leads from 3° on (first 45 s of the waltz: heading drift 7.9° max, 4.7° RMS), K_ψ = 20
(the value here) 5.8° max, 3.8° RMS."""

ABDOMEN_RADIUS = 0.085
"""Radius of the abdomen capsule between the waist and the chest [m]."""
ABDOMEN_HEIGHT = 0.20
"""Height of the abdomen capsule's axis above the waist centre [m]: it spans 0.115–0.285 m, so
between the waist (to 0.10) and the chest (from 0.29) no gap is left that a link could enter."""
ABDOMEN_FORWARD = 0.015
"""Forward offset of the abdomen capsule [m]: its back lies 3 cm in front of the waist's flat
back (the lumbar curve), clear of a forearm held across the waist."""

TORSO = BodyPartSpec(
    name="person_torso",
    geoms=(
        GeomSpec("person_waist", "capsule", (WAIST_RADIUS, WAIST_HALF_LENGTH), (0.0, 0.0, 0.0),
                 axis="y"),
        GeomSpec("person_abdomen", "capsule", (ABDOMEN_RADIUS, 0.07),
                 (ABDOMEN_FORWARD, 0.0, ABDOMEN_HEIGHT), (0.80, 0.62, 0.52, 1.0), axis="y",
                 massless=True),
        GeomSpec("person_chest", "capsule", (0.11, 0.07), (0.0, 0.0, 0.40),
                 (0.35, 0.45, 0.70, 1.0), axis="y"),
        GeomSpec("person_head", "sphere", (0.10,), (0.0, 0.0, 0.72)),
    ),
    mass=30.0,
    stiffness=600.0,
    damping=2.0 * math.sqrt(600.0 * 30.0),
    rot_stiffness=400.0,
    rot_damping=80.0,
    parking=(3.0, -3.0, WAIST_HEIGHT),
    tissue=WAIST_TISSUE,
    max_push=80.0,
)


def _hand(name: str, parking: tuple[float, float, float]) -> BodyPartSpec:
    """A hand: a 0.5 kg sphere on a critically damped 400 N/m spring, parked at ``parking``
    [m] while its script does not use it."""
    return BodyPartSpec(
        name=name,
        geoms=(GeomSpec(name, "sphere", (HAND_RADIUS,)),),
        mass=0.5,
        stiffness=400.0,
        damping=2.0 * math.sqrt(400.0 * 0.5),
        rot_stiffness=1.0,
        rot_damping=0.05,
        parking=parking,
    )


LEFT_HAND = _hand("person_left_hand", (1.4, 0.9, 0.9))
RIGHT_HAND = _hand("person_right_hand", (1.4, -0.9, 0.9))
PERSON_PARTS: tuple[BodyPartSpec, ...] = (TORSO, LEFT_HAND, RIGHT_HAND)
"""The person's parts, in the order used by the ground-truth pose array."""


@dataclass(frozen=True)
class PartTarget:
    """Scripted target of one part at one instant (world frame).

    Attributes:
        position: target position [m].
        velocity: target velocity [m/s] (feeds the damper so a moving target is tracked
            without lag).
        yaw: target heading about world z [rad] (parts stay upright).
        rest: where a teleport puts the part, when that differs from the target: a part that
            leans on the robot rests short of its target by the spring's deflection [m]
            (``None`` = at the target).
    """

    position: FloatArray
    velocity: FloatArray
    yaw: float = 0.0
    rest: FloatArray | None = None
