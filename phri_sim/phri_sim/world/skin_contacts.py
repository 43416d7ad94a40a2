"""The skins inside the simulation: taxel forces and ground truth from MuJoCo contacts (pure).

Per skin link, the contacts between the person's geoms and the link's geoms give

* the ground truth (:class:`LinkGroundTruth`): the total force the person exerts on the link,
  the sum of the contacts' normal forces and their force-weighted mean point;
* per patch on the link, the taxel forces of the footprint model
  (:mod:`phri_sim.world.skin_footprint`): each person geom's normal force spread over the taxels it
  compresses; the seeded sensor model (:mod:`phri_sim.world.skin_sensor`) turns them into a board's
  raw counts, or into the reading of a perfectly tared driver.

Both are computed lazily, once per physics state (:meth:`SimSkins.invalidate` after a step).
"""

from __future__ import annotations

from collections.abc import Collection, Iterator, Mapping, Sequence
from dataclasses import dataclass, field

import mujoco
import numpy as np
from numpy.typing import NDArray

from phri_description.description import CylindricalPatch
from phri_sim.world.robot import SimRobot
from phri_sim.world.skin_footprint import (
    CapsuleShape,
    Shape,
    SkinConfig,
    SkinPatchModel,
    SphereShape,
    layout_for_patch,
)
from phri_sim.world.skin_sensor import PatchSensor

FloatArray = NDArray[np.float64]


@dataclass
class LinkGroundTruth:
    """True contact on one skin link (from the physics, not from the skin).

    Attributes:
        link: link name.
        in_contact: whether any person geom touches the link.
        force_world: total contact force the person exerts on the link, world frame [N].
        force_link: the same in the link frame [N].
        normal_force: sum of the contacts' normal force magnitudes [N].
        center_link: force-weighted mean contact point in the link frame [m].
    """

    link: str
    in_contact: bool = False
    force_world: FloatArray = field(default_factory=lambda: np.zeros(3))
    force_link: FloatArray = field(default_factory=lambda: np.zeros(3))
    normal_force: float = 0.0
    center_link: FloatArray = field(default_factory=lambda: np.zeros(3))


def geom_shape(model: mujoco.MjModel, data: mujoco.MjData, geom: int) -> Shape:
    """A sphere or capsule geom (person geoms are only these) as a world-frame shape [m]."""
    size = model.geom_size[geom]
    half = 0.0 if model.geom_type[geom] == mujoco.mjtGeom.mjGEOM_SPHERE else float(size[1])
    return _shape(data, geom, float(size[0]), half)


def _shape(data: mujoco.MjData, geom: int, radius: float, half_length: float) -> Shape:
    """The world-frame shape of a sphere (``half_length`` 0) or capsule geom [m]."""
    pos = data.geom_xpos[geom]
    if half_length == 0.0:
        return SphereShape(pos.copy(), radius)
    axis = data.geom_xmat[geom][2::3] * half_length  # the geom's z axis (column 2)
    return CapsuleShape(pos - axis, pos + axis, radius)


class SimSkins:
    """The robot's skin patches in a MuJoCo scene (module docstring).

    Args:
        model, data: the scene.
        patches: the description's skin patches.
        config: skin sensor model.
        seed: seed of the sensor model (per-taxel constants and noise; same seed → same
            readings).
        person_geoms: ids of the geoms that belong to the person.
        robot: gives the link poses.

    Attributes:
        patches: patch name → its taxels and footprint model.
        sensors: patch name → its sensor model.
        patch_link: patch name → the link it covers.
        skin_links: the links that carry skin, each once, in patch order.
    """

    def __init__(self, model: mujoco.MjModel, data: mujoco.MjData,
                 patches: Sequence[CylindricalPatch], config: SkinConfig, seed: int,
                 person_geoms: Collection[int], robot: SimRobot) -> None:
        self.model, self.data = model, data
        self.patches = {p.name: SkinPatchModel(layout_for_patch(p), config) for p in patches}
        self.sensors = {p.name: PatchSensor(self.patches[p.name].layout, config.sensor, seed, i)
                        for i, p in enumerate(patches)}
        self.patch_link = {p.name: p.link for p in patches}
        self.skin_links = tuple(dict.fromkeys(p.link for p in patches))
        self._body_link = {model.body(link).id: link for link in self.skin_links}
        self._person_geoms = frozenset(person_geoms)
        self._geom_size = {  # person geom → (radius, capsule half length or 0 for a sphere)
            g: (float(model.geom_size[g][0]),
                0.0 if model.geom_type[g] == mujoco.mjtGeom.mjGEOM_SPHERE
                else float(model.geom_size[g][1]))
            for g in self._person_geoms
        }
        self._robot = robot
        self._truth: dict[str, LinkGroundTruth] | None = None
        self._touch_list: list[tuple[int, str, float, FloatArray]] = []
        self._zeros = {name: np.zeros(p.size) for name, p in self.patches.items()}
        for zeros in self._zeros.values():
            zeros.setflags(write=False)
        self._contacts: dict[str, list[tuple[int, float]]] = {}
        self._dirty = True

    def invalidate(self) -> None:
        """The physics state changed: contacts are collected again on the next read."""
        self._dirty = True

    def reset_noise(self) -> None:
        """Restart the sensor-noise generator from the seed (the per-taxel constants of the
        sensor model belong to the boards and stay)."""
        for sensor in self.sensors.values():
            sensor.reset_noise()

    def _touches(self) -> Iterator[tuple[int, int, str, float]]:
        """(contact index, person geom, skin link, sign) of every person↔skin-link contact; the
        sign turns MuJoCo's contact force (on geom2) into the force on the link."""
        m, d = self.model, self.data
        for i in range(d.ncon):
            con = d.contact[i]
            g1, g2 = int(con.geom1), int(con.geom2)
            if g1 in self._person_geoms:
                person, robot, sign = g1, g2, 1.0
            elif g2 in self._person_geoms:
                person, robot, sign = g2, g1, -1.0
            else:
                continue
            link = self._body_link.get(int(m.geom_bodyid[robot]))
            if link is not None:
                yield i, person, link, sign

    def _update(self) -> None:
        """Collect person↔skin-link contacts (once per state): per link, (person geom, normal
        force); the ground truth is built from them only when asked for."""
        if not self._dirty:
            return
        self._dirty = False
        per_link: dict[str, dict[int, float]] = {}
        touches: list[tuple[int, str, float, FloatArray]] = []
        if self.data.ncon:
            m, d = self.model, self.data
            for i, person, link, sign in self._touches():
                wrench = np.zeros(6)
                mujoco.mj_contactForce(m, d, i, wrench)
                touches.append((i, link, sign, wrench))
                forces = per_link.setdefault(link, {})
                forces[person] = forces.get(person, 0.0) + float(wrench[0])
        self._touch_list = touches
        self._truth = None
        self._contacts = {link: list(v.items()) for link, v in per_link.items()}

    def _build_truth(self) -> dict[str, LinkGroundTruth]:
        """The ground truth per skin link from the collected contacts."""
        d = self.data
        truth = {link: LinkGroundTruth(link) for link in self.skin_links}
        weighted = {link: np.zeros(3) for link in self.skin_links}
        for i, link, sign, wrench in self._touch_list:
            con = d.contact[i]
            frame = con.frame.reshape(3, 3)
            # Contact force acts on geom2 along +normal (frame row 0 points geom1 → geom2).
            fn = float(wrench[0])
            gt = truth[link]
            gt.in_contact = True
            gt.force_world += sign * (frame.T @ wrench[:3])
            gt.normal_force += fn
            weighted[link] += fn * con.pos
        for link, gt in truth.items():
            if gt.in_contact:
                rot, pos = self._robot.link_pose(link)
                gt.force_link = rot.T @ gt.force_world
                if gt.normal_force > 0.0:
                    gt.center_link = rot.T @ (weighted[link] / gt.normal_force - pos)
        return truth

    def clean_forces(self) -> dict[str, FloatArray]:
        """Per-patch noise-free taxel forces [N] now (patch → (N,)), the footprint model of
        :mod:`phri_sim.world.skin_footprint`; an untouched patch is all zeros (a shared read-only
        array)."""
        self._update()
        out: dict[str, FloatArray] = {}
        for name, patch in self.patches.items():
            link = self.patch_link[name]
            contacts = self._contacts.get(link, [])
            if contacts:
                rot, pos = self._robot.link_pose(link)
                forces = patch.forces(rot, pos, [(_shape(self.data, g, *self._geom_size[g]), fn)
                                                 for g, fn in contacts],
                                      keys=[g for g, _ in contacts])
            else:
                forces = self._zeros[name]
            out[name] = forces
        return out

    def reading(self, patch: str, forces: FloatArray) -> FloatArray:
        """One sample of what a patch reports [N] for true forces ``forces`` without the
        driver in the loop: its board's counts now, read with a perfect tare (sensor model)."""
        sensor = self.sensors[patch]
        return sensor.reading(sensor.counts(forces, float(self.data.time)))

    def forces(self, noise: bool = True) -> dict[str, FloatArray]:
        """Per-patch taxel forces [N] now (patch → (N,)): the sensor model's reading when
        ``noise``, else the true (footprint) forces."""
        clean = self.clean_forces()
        if not noise:
            return clean
        return {name: self.reading(name, f) for name, f in clean.items()}

    def ground_truth(self) -> Mapping[str, LinkGroundTruth]:
        """True contact per skin link at the current state (see :class:`LinkGroundTruth`)."""
        self._update()
        if self._truth is None:
            self._truth = self._build_truth()
        return self._truth
