"""Simulated skin: taxel grids on the link surfaces and per-taxel normal forces (pure, no rclpy).

Taxel grids come from :func:`skin_driver.layout.cylindrical_patch` with the description's patch
geometry (:func:`layout_for_patch`), so the simulated skin and skin_driver agree on taxel order,
positions and normals.

Footprint model. MuJoCo reports a contact between a person geom and a link as one or a few
points, which would light single taxels (design §5). The skin and the tissue under it are instead
modelled as a thin elastic (Winkler) layer of thickness ``h`` (:attr:`SkinConfig.softness`): a
taxel at signed distance ``d_j`` from the person geom's surface (negative inside) is compressed by
``e_j = max(0, h − d_j)``, and its share of the contact's normal force is proportional to that
compression::

    f_j = F_n · e_j / Σ_k e_k

where ``F_n`` is the physical normal force MuJoCo computed between that geom and the link. So the
taxels' total equals the contact force exactly (before noise), the pressure is highest where the
person sinks in deepest, and even a tangent sphere lights a disc of radius ≈ √(2 R_eff h)
(R_eff = R_person R_link / (R_person + R_link)), i.e. several taxels at 7.5 mm pitch.

Sensor model (:mod:`phri_sim.world.skin_sensor`): ADC counts with per-taxel gain error and zero
offset, noise, quantisation and a few dead taxels; :class:`SkinConfig` carries its parameters.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from phri_description.description import CylindricalPatch
from phri_sim.world.skin_sensor import SensorConfig
from skin_driver.layout import SkinLayout, cylindrical_patch

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class SkinConfig:
    """Skin model: footprint and sensor (:class:`~phri_sim.world.skin_sensor.SensorConfig`).

    Attributes:
        softness: thickness h of the compliant layer of the footprint model [m].
        noise_std: per-taxel noise, standard deviation [N] (0 = noiseless).
        gain_error_std: per-taxel relative gain error, standard deviation [-].
        offset_std: per-taxel zero offset, standard deviation [count].
        dead_taxels: taxels per patch that never respond [-].
    """

    softness: float = 0.004
    noise_std: float = 0.005
    gain_error_std: float = 0.05
    offset_std: float = 20.0
    dead_taxels: int = 3

    def __post_init__(self) -> None:
        if not (np.isfinite(self.softness) and self.softness > 0.0):
            raise ValueError(f"skin softness must be a positive length [m], got {self.softness}")
        self.sensor  # noqa: B018  (validates the sensor settings)

    @property
    def sensor(self) -> SensorConfig:
        """The sensor model's parameters."""
        return SensorConfig(self.noise_std, self.gain_error_std, self.offset_std,
                            self.dead_taxels)


def layout_for_patch(patch: CylindricalPatch) -> SkinLayout:
    """The taxel layout of a description patch, from skin_driver's generator (same order)."""
    return cylindrical_patch(
        patch.name,
        patch.link,
        patch.radius,
        patch.axial_range,
        angle_range=patch.angular_range,
        axis_point=patch.point,
        axis=patch.axis,
        reference=patch.zero_direction,
    )


@dataclass(frozen=True)
class SphereShape:
    """A sphere (world frame): centre [m], radius [m]."""

    center: FloatArray
    radius: float

    def signed_distance(self, points: FloatArray) -> FloatArray:
        """Signed distance [m] of (N, 3) points to the surface (negative inside)."""
        d = points - self.center
        return np.asarray(np.sqrt(np.einsum("ij,ij->i", d, d)) - self.radius)

    def in_frame(self, rotation: FloatArray, position: FloatArray) -> SphereShape:
        """The same sphere in a frame with pose (⁰R, ⁰p) in the world."""
        return SphereShape(rotation.T @ (self.center - position), self.radius)

    def bounding_sphere(self) -> tuple[FloatArray, float]:
        """(centre, radius) [m] of a sphere enclosing the shape."""
        return self.center, self.radius

    def displacement(self, other: Shape) -> float:
        """Largest distance [m] any point of this shape moved to become ``other`` (inf for a
        different shape): a signed distance changes by at most this much."""
        if not isinstance(other, SphereShape) or other.radius != self.radius:
            return math.inf
        return math.dist(other.center, self.center)


@dataclass(frozen=True)
class CapsuleShape:
    """A capsule (world frame): segment end points ``a``, ``b`` [m] and radius [m]."""

    a: FloatArray
    b: FloatArray
    radius: float

    def signed_distance(self, points: FloatArray) -> FloatArray:
        """Signed distance [m] of (N, 3) points to the surface (negative inside)."""
        ab = self.b - self.a
        denom = float(ab @ ab)
        ap = points - self.a
        if denom > 0.0:
            t = np.clip(ap @ (ab / denom), 0.0, 1.0)
            ap -= t[:, None] * ab
        return np.asarray(np.sqrt(np.einsum("ij,ij->i", ap, ap)) - self.radius)

    def in_frame(self, rotation: FloatArray, position: FloatArray) -> CapsuleShape:
        """The same capsule in a frame with pose (⁰R, ⁰p) in the world."""
        return CapsuleShape(rotation.T @ (self.a - position), rotation.T @ (self.b - position),
                            self.radius)

    def bounding_sphere(self) -> tuple[FloatArray, float]:
        """(centre, radius) [m] of a sphere enclosing the shape."""
        half = 0.5 * float(np.linalg.norm(self.b - self.a))
        return 0.5 * (self.a + self.b), half + self.radius

    def displacement(self, other: Shape) -> float:
        """Largest distance [m] any point of this shape moved to become ``other`` (inf for a
        different shape; a segment's points move at most as far as its ends)."""
        if not isinstance(other, CapsuleShape) or other.radius != self.radius:
            return math.inf
        return max(math.dist(other.a, self.a), math.dist(other.b, self.b))


Shape = SphereShape | CapsuleShape


def footprint_weights(taxels_world: FloatArray, shape: Shape, softness: float) -> FloatArray:
    """Compression e_j = max(0, h − d_j) [m] of every taxel under ``shape`` (module docstring)."""
    return np.maximum(softness - shape.signed_distance(taxels_world), 0.0)


def distribute(total: float, weights: FloatArray) -> FloatArray:
    """Split a normal force ``total`` [N] over taxels in proportion to ``weights``.

    Returns zeros when no taxel is compressed (the contact is off the skin).
    """
    s = float(weights.sum())
    if total <= 0.0 or s <= 0.0:
        return np.zeros_like(weights)
    return np.asarray(weights * (total / s))


NEAR_MARGIN = 0.005
"""Band [m] beyond the compliant layer kept in a contact's cached candidate taxels."""


class SkinPatchModel:
    """One patch's taxels and their forces from a list of (shape, normal force) contacts.

    Candidate taxels. Only taxels within the compliant layer of a shape carry force. For a
    contact with a key (the person geom), the taxels within ``h +`` :data:`NEAR_MARGIN` of the
    shape are kept and reused while the shape (in the link frame) has moved less than the
    margin since: a signed distance changes by at most the shape's displacement, so no taxel
    the shape now compresses can be outside the kept set (exact, not an approximation). The
    500 Hz skin then evaluates the footprint on a few dozen taxels instead of thousands.
    """

    def __init__(self, layout: SkinLayout, config: SkinConfig | None = None) -> None:
        self.layout = layout
        self.config = config or SkinConfig()
        self.positions = layout.positions
        self.normals = layout.normals
        self.size = layout.size
        self._near: dict[int, tuple[Shape, NDArray[np.intp]]] = {}

    def forces(
        self,
        rotation: FloatArray,
        position: FloatArray,
        contacts: Iterable[tuple[Shape, float]],
        keys: Sequence[int] | None = None,
    ) -> FloatArray:
        """Noise-free per-taxel normal forces [N] for the link pose and the touching shapes.

        Args:
            rotation, position: link pose in the world.
            contacts: (person geom shape, normal force [N] between it and this link).
            keys: per contact, a key of its shape (the geom id) for the candidate cache (class
                docstring); ``None``: no cache.
        """
        out = np.zeros(self.size)
        h = self.config.softness
        for i, (shape, normal_force) in enumerate(contacts):
            if normal_force <= 0.0:
                continue
            # In the link frame (the taxel positions are stored there).
            local = shape.in_frame(rotation, position)
            near = self._candidates(local, None if keys is None else keys[i])
            if near.size == 0:
                continue
            weights = footprint_weights(self.positions[near], local, h)
            out[near] += distribute(normal_force, weights)
        return out

    def _candidates(self, local: Shape, key: int | None) -> NDArray[np.intp]:
        """Indices of the taxels that can be within the compliant layer of ``local``."""
        h = self.config.softness
        if key is None:
            centre, reach = local.bounding_sphere()
            d = self.positions - centre
            return np.flatnonzero(np.einsum("ij,ij->i", d, d) < (reach + h) ** 2)
        cached = self._near.get(key)
        if cached is not None and cached[0].displacement(local) < NEAR_MARGIN:
            return cached[1]
        near = np.flatnonzero(local.signed_distance(self.positions) < h + NEAR_MARGIN)
        self._near[key] = (local, near)
        return near
