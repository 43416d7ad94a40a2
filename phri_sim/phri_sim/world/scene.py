"""The simulation scene: the one robot description plus actuators, floor and the person.

Everything robot-shaped comes from :func:`phri_description.mujoco_model.build_spec` (no second
robot description); this module only adds what a simulation needs on top of that spec:

* **Actuators** (``<joint>_vel``): velocity servos, like the real hardware. The base's three
  virtual joints ``base_x``, ``base_y`` (slides along odom x/y) and ``base_yaw`` follow world-frame
  rates that :class:`~phri_sim.world.simulation.Simulation` computes from the commanded body twist;
  the twelve UR joints follow their commanded joint velocities. Gains are stiff (a 50 N push changes
  the base speed by 50 / :data:`BASE_KV` m/s) and forces are capped at the UR16e effort limits. The
  arm links are gravity compensated, as the UR controller does internally.
* **Contacts**: robot geoms use ``contype = 1, conaffinity = 2`` and person geoms ``contype = 2,
  conaffinity = 1``, so the person touches the robot, while neither self-collides nor touches the
  floor (the base moves on its virtual joints; the person's weight is carried by its springs).
* **Person**: the free bodies of :mod:`phri_sim.world.person_body`.
* **Floor and light** (``scene`` only).

:func:`write_models` writes ``robot.xml`` (robot + actuators) and ``scene.xml`` (the full scene)
in the MuJoCo Menagerie layout; ``python -m phri_sim.world.scene DIR`` does it from the command
line.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import mujoco
import numpy as np

from phri_description.description import JOINT_NAMES
from phri_description.mujoco_model import build_spec
from phri_sim.world.person_body import PERSON_PARTS, BodyPartSpec, GeomSpec

BASE_KV: tuple[float, float, float] = (2.0e4, 2.0e4, 1.0e4)
"""Velocity-servo gains of base x [N·s/m], y [N·s/m] and yaw [N·m·s/rad]."""
BASE_FORCE_LIMIT: tuple[float, float, float] = (3000.0, 3000.0, 1500.0)
"""Force/torque caps of the base servos [N], [N], [N·m]."""
ARM_KV: tuple[float, ...] = (3000.0, 3000.0, 1500.0, 300.0, 300.0, 300.0)
"""Velocity-servo gains of UR joints 1…6 [N·m·s/rad]."""
ARM_ARMATURE: tuple[float, ...] = (0.5, 0.5, 0.3, 0.05, 0.05, 0.05)
"""Reflected rotor inertia of UR joints 1…6 [kg·m²] (keeps the stiff servos well conditioned)."""
TIMESTEP = 0.002
"""Physics step [s] (= the 500 Hz skin sampling period)."""
ROBOT_CONTYPE, ROBOT_CONAFFINITY = 1, 2
PERSON_CONTYPE, PERSON_CONAFFINITY = 2, 1
PERSON_FRICTION = 0.3
"""Sliding friction of the person's geoms (skin on cloth/skin): low, so hands can slide. Person
geoms have contact priority 1, so this value (not MuJoCo's default maximum of the two geoms', 1.0
on the robot) and the person's solref/solimp below govern every person–robot contact."""
PERSON_PRIORITY = 1
PERSON_SOLREF: tuple[float, float] = (0.02, 1.0)
"""Contact time constant [s] and damping ratio of the person's surface (skin and clothes)."""
PERSON_SOLIMP: tuple[float, float, float, float, float] = (0.0001, 0.95, 0.002, 0.5, 2.0)
"""Contact impedance of the person's surface: it rises from ≈ 0 at first touch to 0.95 over
2 mm of penetration, so the contact force grows smoothly from zero with the indentation (≈ 1 mm
at 10 N) instead of jumping. With MuJoCo's default (0.9 at zero penetration) the contact is
stiff to within some 20 µm, and the micrometre jitter of a velocity-servoed link sliding under a
light body makes it flicker on and off between physics steps."""

ACTUATOR_SUFFIX = "_vel"


def _effort_limits() -> dict[str, float]:
    from phri_description.description import robot_description

    desc = robot_description()
    return {name: desc.joint(name).effort for name in JOINT_NAMES[3:]}


def _add_actuators(spec: mujoco.MjSpec) -> None:
    efforts = _effort_limits()
    gains = dict(zip(JOINT_NAMES[:3], BASE_KV, strict=True))
    limits = dict(zip(JOINT_NAMES[:3], BASE_FORCE_LIMIT, strict=True))
    arm = JOINT_NAMES[3:]
    for i, name in enumerate(arm):
        gains[name] = ARM_KV[i % 6]
        limits[name] = efforts[name]
    for name in JOINT_NAMES:
        act = spec.add_actuator()
        act.name = name + ACTUATOR_SUFFIX
        act.target = name
        act.trntype = mujoco.mjtTrn.mjTRN_JOINT
        act.set_to_velocity(kv=gains[name])
        act.forcelimited = mujoco.mjtLimited.mjLIMITED_TRUE
        act.forcerange = [-limits[name], limits[name]]
    for joint in spec.joints:
        if joint.name in arm:
            joint.armature = ARM_ARMATURE[arm.index(joint.name) % 6]


def _robot_collisions(spec: mujoco.MjSpec) -> None:
    for geom in spec.geoms:
        geom.contype = ROBOT_CONTYPE
        geom.conaffinity = ROBOT_CONAFFINITY


def _gravity_compensate_arms(spec: mujoco.MjSpec) -> None:
    for body in spec.bodies:
        if body.name.startswith(("left_", "right_")):
            body.gravcomp = 1.0


def _capsule_or_sphere_volume(g: GeomSpec) -> float:
    volume = 4.0 / 3.0 * np.pi * g.size[0] ** 3
    if g.shape == "capsule":
        volume += 2.0 * np.pi * g.size[0] ** 2 * g.size[1]
    return float(volume)


_AXIS_QUAT: dict[str, tuple[float, float, float, float]] = {
    "z": (1.0, 0.0, 0.0, 0.0),
    "y": (math.sqrt(0.5), -math.sqrt(0.5), 0.0, 0.0),
    "x": (math.sqrt(0.5), 0.0, math.sqrt(0.5), 0.0),
}
"""Geom orientation that lays a capsule's z axis along the body axis named (w x y z)."""


def _add_geoms(body: mujoco.MjsBody, geoms: list[GeomSpec], mass: float) -> None:
    """Add the part's geoms to ``body`` with ``mass`` [kg] spread by volume (uniform density)
    over the geoms that are not massless."""
    volume = sum(_capsule_or_sphere_volume(g) for g in geoms if not g.massless)
    for g in geoms:
        geom = body.add_geom()
        geom.name = g.name
        geom.type = (
            mujoco.mjtGeom.mjGEOM_SPHERE if g.shape == "sphere" else mujoco.mjtGeom.mjGEOM_CAPSULE
        )
        size = np.zeros(3)
        size[: len(g.size)] = g.size
        geom.size = size
        geom.pos = np.array(g.pos)
        geom.quat = np.array(_AXIS_QUAT[g.axis])
        geom.rgba = np.array(g.rgba)
        geom.contype = PERSON_CONTYPE
        geom.conaffinity = PERSON_CONAFFINITY
        geom.condim = 3
        geom.friction = np.array([PERSON_FRICTION, 0.005, 0.0001])
        geom.priority = PERSON_PRIORITY
        geom.solref = np.array(PERSON_SOLREF)
        geom.solimp = np.array(PERSON_SOLIMP)
        geom.density = 0.0 if g.massless else mass / volume


def _add_part(spec: mujoco.MjSpec, part: BodyPartSpec) -> None:
    body = spec.worldbody.add_body()
    body.name = part.name
    body.pos = np.array(part.parking)
    body.gravcomp = 1.0
    body.add_freejoint().name = part.name + "_free"
    tissue = part.tissue
    soft = set(tissue.geoms) if tissue is not None else set()
    unknown = soft - {g.name for g in part.geoms}
    if unknown:
        raise ValueError(f"{part.name}: tissue geoms {sorted(unknown)} are not geoms of the part")
    rigid = [g for g in part.geoms if g.name not in soft]
    tissue_mass = tissue.mass if tissue is not None else 0.0
    if rigid:
        _add_geoms(body, rigid, part.mass - tissue_mass)
    if tissue is None:
        return
    # The compliant layer (person.SoftTissue): a light body on two horizontal slide joints with
    # a spring and a damper each, carrying the soft geoms.
    layer = body.add_body()
    layer.name = part.tissue_body
    layer.gravcomp = 1.0
    for axis_name, axis in (("x", (1.0, 0.0, 0.0)), ("y", (0.0, 1.0, 0.0))):
        joint = layer.add_joint()
        joint.name = f"{part.tissue_body}_{axis_name}"
        joint.type = mujoco.mjtJoint.mjJNT_SLIDE
        joint.axis = np.array(axis)
        joint.stiffness = np.array([tissue.stiffness, 0.0, 0.0])
        joint.damping = np.array([tissue.damping, 0.0, 0.0])
        joint.springref = 0.0
        joint.limited = mujoco.mjtLimited.mjLIMITED_TRUE
        joint.range = np.array([-tissue.travel, tissue.travel])
    if tissue.yaw_stiffness > 0.0:
        hinge = layer.add_joint()
        hinge.name = f"{part.tissue_body}_yaw"
        hinge.type = mujoco.mjtJoint.mjJNT_HINGE
        hinge.axis = np.array([0.0, 0.0, 1.0])
        hinge.stiffness = np.array([tissue.yaw_stiffness, 0.0, 0.0])
        hinge.damping = np.array([tissue.yaw_damping, 0.0, 0.0])
        hinge.springref = 0.0
        hinge.limited = mujoco.mjtLimited.mjLIMITED_TRUE
        hinge.range = np.array([-tissue.yaw_travel, tissue.yaw_travel])
    _add_geoms(layer, [g for g in part.geoms if g.name in soft], tissue.mass)


def robot_spec() -> mujoco.MjSpec:
    """The robot with its velocity servos (``robot.xml``)."""
    spec = build_spec()
    spec.modelname = "phri_robot"
    spec.option.timestep = TIMESTEP
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    _robot_collisions(spec)
    _gravity_compensate_arms(spec)
    _add_actuators(spec)
    return spec


FLOOR_TILE = 0.5
"""Side of the floor's checker squares [m] (a dance floor's tiles: motion and turns show)."""


def _add_floor(spec: mujoco.MjSpec) -> None:
    """A visual floor (no collisions): light/dark checker squares of :data:`FLOOR_TILE` with
    thin lines on their edges."""
    tex = spec.add_texture()
    tex.name = "floor_checker"
    tex.type = mujoco.mjtTexture.mjTEXTURE_2D
    tex.builtin = mujoco.mjtBuiltin.mjBUILTIN_CHECKER
    tex.mark = mujoco.mjtMark.mjMARK_EDGE
    tex.rgb1 = np.array([0.62, 0.64, 0.68])
    tex.rgb2 = np.array([0.48, 0.50, 0.55])
    tex.markrgb = np.array([0.85, 0.85, 0.88])
    tex.width = tex.height = 256
    mat = spec.add_material()
    mat.name = "floor_tiles"
    mat.textures[mujoco.mjtTextureRole.mjTEXROLE_RGB] = tex.name
    mat.texuniform = True
    mat.texrepeat = np.array([0.5 / FLOOR_TILE, 0.5 / FLOOR_TILE])
    floor = spec.worldbody.add_geom()
    floor.name = "floor"
    floor.type = mujoco.mjtGeom.mjGEOM_PLANE
    floor.size = np.array([0.0, 0.0, 0.05])
    floor.material = mat.name
    floor.contype = 0
    floor.conaffinity = 0


def scene_spec(parts: tuple[BodyPartSpec, ...] = PERSON_PARTS) -> mujoco.MjSpec:
    """The full simulation scene: robot, floor, light and the person (``scene.xml``)."""
    spec = robot_spec()
    spec.modelname = "phri_scene"
    _add_floor(spec)
    light = spec.worldbody.add_light()
    light.name = "sun"
    light.pos = np.array([0.0, 0.0, 4.0])
    light.dir = np.array([0.0, 0.0, -1.0])
    for part in parts:
        _add_part(spec, part)
    # Keyframes would have to list the person's free joints too; the scenarios set the state.
    for key in list(spec.keys):
        spec.delete(key)
    return spec


def write_models(directory: str | Path) -> tuple[Path, Path]:
    """Write ``robot.xml`` and ``scene.xml`` into ``directory``; return their paths."""
    out = Path(directory)
    out.mkdir(parents=True, exist_ok=True)
    robot = robot_spec()
    for key in list(robot.keys):
        robot.delete(key)
    robot.compile()
    scene = scene_spec()
    scene.compile()
    robot_path, scene_path = out / "robot.xml", out / "scene.xml"
    robot_path.write_text(robot.to_xml(), encoding="utf-8")
    scene_path.write_text(scene.to_xml(), encoding="utf-8")
    return robot_path, scene_path


MODELS_DIR = Path(__file__).resolve().parent / "models"
"""Where the generated ``robot.xml`` and ``scene.xml`` are kept (package data)."""


def main(argv: list[str] | None = None) -> None:
    """``python -m phri_sim.world.scene [DIR]``: write robot.xml and scene.xml (default: the
    package's models directory)."""
    parser = argparse.ArgumentParser(description=main.__doc__)
    parser.add_argument("directory", nargs="?", default=str(MODELS_DIR))
    args = parser.parse_args(argv)
    for path in write_models(args.directory):
        print(path)


if __name__ == "__main__":
    main()
