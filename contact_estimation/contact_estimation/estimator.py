"""Contact estimation core: taxel forces → one contact state per link (paper Sec. IV-A/B).

Pure numpy, no rclpy. For every link the estimator turns the taxels whose normal force exceeds
the threshold σ_t into

* the contact centre ᶦp_η, the ω-weighted mean of their positions (eq. 5);
* the resultant force ᶦf_η = Σ ω ᶦf_σ (eq. 9a);
* the torque about the centre ᶦτ_η = Σ (ᶦp_σ − ᶦp_η) × ω ᶦf_σ (eq. 9b), limited per axis;
* the contact region Ω_i, the axis-aligned box of the contacting taxel positions (Sec. IV-B);
* the number of taxels in contact, or the explicit no-contact state.

All quantities are in the link frame γ_i. Each taxel measures a normal force only: the force it
exerts on the link is ᶦf_σ = −force · n̂ (n̂ the outward normal; the person pushes into the skin).

Several skin patches may belong to one link. A patch's geometry (positions, normals, weights) is
fixed by its calibrated layout, so the estimator precomputes, per taxel, the rows
``[ω p, ω, 1, −ω n, −ω (p × n), p]``. With the contact mask m and forces F, every sum in
(5), (9a), (9b) is then a masked sum of those rows (``Σ p × ωf = −Σ ω F (p × n)``, and
``Σ (p − c) × f = Σ p × f − c × Σ f``), computed for all links at once with a gather and a
segmented reduction: about ten numpy calls per step whatever the number of links and patches.
This gives exactly the sums over the union of a link's patches, with no per-taxel Python loop.
That numpy version is the reference; by default (``kernel="numba"``) each patch's sums are
computed when its frame arrives, in the compiled pass that also checks the frame
(:mod:`contact_estimation.patch_sums`), and an estimate only adds each link's patch rows. Both
kernels turn the sums into states with one compiled function (:func:`patch_sums.link_states`).

Bad input handling (documented in docs/contact_estimation.md), checked on every frame:

* non-finite forces, positions, normals or weights → the frame is refused with
  :class:`InvalidTaxelData` (nothing is updated, the patch keeps its previous frame);
* a force beyond the skin's rated range, |force| > ``max_taxel_force`` → refused the same way
  (a corrupted value: a finite 3e38 N would otherwise pass through as a contact force);
* an empty cloud → refused (a patch has at least one taxel);
* negative forces within the range (noise below the tare) are below any threshold σ_t ≥ 0:
  never in contact;
* arrays of mismatched size → :class:`InvalidTaxelData`;
* a frame whose geometry differs from the patch's (another taxel count or weighting, always
  checked; other positions, normals or weights, checked when ``check_geometry``) →
  :class:`GeometryMismatch`: a patch's geometry is learnt from its first frame (or given by
  :meth:`ContactEstimator.set_geometry`) and changes only when announced
  (:meth:`ContactEstimator.forget_geometry`), never from one odd frame;
* a patch the estimator was not configured with → :class:`UnknownPatchError`.

The checks are cheap enough for every frame (:func:`check_forces`,
:func:`check_geometry_values`): a sum test per array (a BLAS product, fTf for the forces, 1ᵀA
for positions and normals); only a test that fails triggers the exact element-wise check.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

import contact_estimation.patch_sums as patch_sums
from contact_estimation.frame_checks import (
    DEFAULT_MAX_TAXEL_FORCE,
    MAX_TAXEL_FORCE_RANGE,
    GeometryMismatch,
    InvalidTaxelData,
    StuckDetector,
    UnknownPatchError,
    check_forces,
    check_geometry_values,
    check_shapes,
)
from phri_common import paper
from phri_common.records import ContactState, TaxelArray

FloatArray = NDArray[np.floating]

PAPER_TORQUE_LIMIT = paper.TORQUE_LIMIT
"""The paper limits the estimated torque's third component to 1.2 N·m (Sec. VI-A.1)."""

KERNELS = ("numba", "numpy")
"""Allowed values of ``kernel``: the per-link sums compiled (:mod:`contact_estimation.patch_sums`,
the default) or in numpy (the reference, :meth:`ContactEstimator._link_sums_numpy`)."""


@dataclass(frozen=True)
class EstimatorConfig:
    """Parameters of the contact estimation.

    Attributes:
        force_threshold: σ_t [N]; a taxel is in contact when its force is strictly greater.
        torque_limit: per-axis bound on |ᶦτ_η| [N·m] in the link frame (the paper clamps the third
            component to 1.2; ``inf`` = no limit). The estimated torque is clamped to
            ``[-limit, limit]`` on each axis.
        max_taxel_force: the skin's rated range [N]: a frame with any |force| above it is
            refused as corrupted (:data:`~contact_estimation.frame_checks.DEFAULT_MAX_TAXEL_FORCE`).
        stuck_timeout: a touched patch whose forces repeat bit for bit for longer than this [s]
            (by frame stamps) is stuck, and its frames are refused (:class:`StuckDetector`).
        kernel: how the per-link sums are computed, one of :data:`KERNELS`; both give the same
            states (to rounding), the compiled one several times faster.
    """

    force_threshold: float = 0.05
    torque_limit: tuple[float, float, float] = PAPER_TORQUE_LIMIT
    max_taxel_force: float = DEFAULT_MAX_TAXEL_FORCE
    stuck_timeout: float = 0.5
    kernel: str = KERNELS[0]

    def __post_init__(self) -> None:
        if self.kernel not in KERNELS:
            raise ValueError(f"kernel refused value {self.kernel!r}: allowed {list(KERNELS)}")
        if not (math.isfinite(self.force_threshold) and self.force_threshold >= 0.0):
            raise ValueError(
                f"force_threshold [N] refused value {self.force_threshold}: allowed range "
                "[0, inf), finite"
            )
        if len(self.torque_limit) != 3 or any(
            math.isnan(t) or t < 0.0 for t in self.torque_limit
        ):
            raise ValueError(
                f"torque_limit [N·m] refused value {self.torque_limit}: allowed 3 values in "
                "[0, inf]"
            )
        if not 0.0 < self.stuck_timeout < math.inf:  # also refuses NaN
            raise ValueError(f"stuck_timeout [s] refused value {self.stuck_timeout}: allowed "
                             "range (0, inf)")
        low, high = MAX_TAXEL_FORCE_RANGE
        if not low <= self.max_taxel_force <= high:  # also refuses NaN
            raise ValueError(
                f"max_taxel_force [N] refused value {self.max_taxel_force}: allowed range "
                f"[{low:g}, {high:g}]"
            )


# Geometry rows per taxel (see module docstring). Without per-taxel weights ω p = p and Σ ω is the
# count, so the cheaper layout (9 rows) is used; with weights 13 rows.
_P, _F, _M = slice(0, 3), slice(3, 6), slice(6, 9)  # p, −ω n, −ω (p × n)
_WP, _W = slice(9, 12), 12  # ω p, ω (weighted layout only)
_FORCE_ROWS = slice(3, 9)  # rows multiplied by the taxel force


def _geometry_rows(
    positions: FloatArray, normals: FloatArray, weights: FloatArray | None, weighted: bool
) -> NDArray[np.float64]:
    """Per-taxel geometry rows (9 or 13, N): p, −ω n, −ω (p × n)[, ω p, ω]."""
    p = np.asarray(positions, dtype=np.float64)
    n = np.asarray(normals, dtype=np.float64)
    w = np.ones(p.shape[0]) if weights is None else np.asarray(weights, dtype=np.float64)
    rows = np.empty((13 if weighted else 9, p.shape[0]))
    rows[_P] = p.T
    rows[_F] = -(n * w[:, None]).T
    p_cross_n = np.stack(
        [
            p[:, 1] * n[:, 2] - p[:, 2] * n[:, 1],
            p[:, 2] * n[:, 0] - p[:, 0] * n[:, 2],
            p[:, 0] * n[:, 1] - p[:, 1] * n[:, 0],
        ]
    )
    rows[_M] = -p_cross_n * w
    if weighted:
        rows[_WP] = (p * w[:, None]).T
        rows[_W] = w
    return rows


class ContactEstimator:
    """Per-link contact estimation over a fixed set of skin patches.

    Each patch's geometry is taken from its first frame (or given by :meth:`set_geometry`);
    a later frame with another geometry is refused (:class:`GeometryMismatch`) until
    :meth:`forget_geometry` announces a new one. :meth:`update` folds in one patch frame,
    :meth:`estimate` returns every link's state.

    Args:
        patch_links: patch name → link frame name (several patches may share a link).
        config: thresholds and limits.
    """

    def __init__(self, patch_links: Mapping[str, str], config: EstimatorConfig | None = None):
        if not patch_links:
            raise ValueError("at least one patch is required")
        self.config = config or EstimatorConfig()
        self.patch_links = dict(patch_links)
        for patch, link in self.patch_links.items():
            if not link:
                raise ValueError(f"patch {patch!r} has an empty link name")
        # Patches ordered by link so each link's taxels form one contiguous column range.
        self.links: dict[str, list[str]] = {}
        for patch, link in self.patch_links.items():
            self.links.setdefault(link, []).append(patch)
        self._order = [p for patches in self.links.values() for p in patches]
        self._geometry: dict[str, tuple[FloatArray, FloatArray, FloatArray | None]] = {}
        self._stamps: dict[str, int] = dict.fromkeys(self.patch_links, 0)
        self._taken: dict[str, tuple[FloatArray, FloatArray, FloatArray | None]] = {}
        self._stuck = StuckDetector(self.config.stuck_timeout)
        self._set_config(self.config)
        self._build()

    def reconfigure(self, config: EstimatorConfig) -> None:
        """Switch to new thresholds/limits; the next estimate uses them."""
        self._set_config(config)
        self._sum_patches()

    def _set_config(self, config: EstimatorConfig) -> None:
        self.config = config
        self._limit = np.array(config.torque_limit, dtype=np.float64)
        self._numba = config.kernel == "numba"
        self._limit2 = config.max_taxel_force * config.max_taxel_force  # [N²]
        if self._numba:
            patch_sums.warm_up()

    def _sum_patches(self) -> None:
        """Every patch's sums from its stored forces (the numba kernel's per-patch table)."""
        patch_sums.all_patch_sums(self._forces, self._rows_t, self._bounds,
                             self.config.force_threshold, self._patch_table)

    def _build(self) -> None:
        """(Re)build the concatenated geometry rows, force buffer and column ranges.

        Forces of patches whose geometry did not change are kept.
        """
        old_columns = getattr(self, "_columns", {})
        old_forces = getattr(self, "_forces", np.zeros(1))
        blocks, self._columns = [], {}
        start = 0
        self._weighted = any(g[2] is not None for g in self._geometry.values())
        for patch in self._order:
            geometry = self._geometry.get(patch)
            count = 0 if geometry is None else geometry[0].shape[0]
            if geometry is not None:
                blocks.append(_geometry_rows(*geometry, weighted=self._weighted))
            self._columns[patch] = (start, start + count)
            start += count
        self._total = start
        # One extra always-contacting sentinel column with zero rows: it keeps every segment
        # bound of the reduction a valid index (see _compute).
        self._rows = np.concatenate(
            [*blocks, np.zeros((13 if self._weighted else 9, 1))], axis=1
        )
        self._forces = np.zeros(start + 1)
        self._forces[start] = 1e300
        for patch, (c0, c1) in self._columns.items():
            o0, o1 = old_columns.get(patch, (0, 0))
            if o1 - o0 == c1 - c0:
                self._forces[c0:c1] = old_forces[o0:o1]
        self._link_starts = []
        for patches in self.links.values():
            self._link_starts.append(self._columns[patches[0]][0])
        self._link_items = list(self.links.items())
        self._link_index = {link: i for i, (link, _) in enumerate(self._link_items)}
        self._link_starts.append(start)
        # The compiled kernel's inputs: rows per taxel, one row of sums per patch (in link
        # order), each link's first patch row; the reference's identity grouping (a row per link).
        self._rows_t = np.ascontiguousarray(self._rows[:, :start].T)
        self._slots = {p: (*self._columns[p], k) for k, p in enumerate(self._order)}
        self._bounds = np.array([self._columns[p][0] for p in self._order] + [start],
                                dtype=np.int64)
        self._groups = np.cumsum([0] + [len(p) for p in self.links.values()], dtype=np.int64)
        self._link_rows = np.arange(len(self._link_items) + 1, dtype=np.int64)
        self._counts = np.zeros(len(self._link_items), dtype=np.int64)
        width = self._rows.shape[0] + patch_sums.TABLE_EXTRA
        self._patch_table = np.empty((len(self._order), width))
        self._sum_patches()

    def set_geometry(
        self,
        patch: str,
        positions: FloatArray,
        normals: FloatArray,
        weights: FloatArray | None = None,
    ) -> None:
        """Set a patch's taxel geometry (link frame) ahead of its first frame."""
        self._patch_link(patch)
        check_shapes(positions, normals, np.zeros(positions.shape[0]), weights)
        try:
            check_geometry_values(positions, normals, weights)
        except InvalidTaxelData as err:
            raise InvalidTaxelData(f"patch {patch!r}: {err}") from err
        copy = None if weights is None else np.array(weights, dtype=np.float64)
        self._taken.pop(patch, None)  # the next frame's geometry is checked against this one
        if patch in self._columns:  # a new geometry invalidates the patch's old forces
            c0, c1 = self._columns[patch]
            self._forces[c0:c1] = 0.0
        self._geometry[patch] = (
            np.array(positions, dtype=np.float64),
            np.array(normals, dtype=np.float64),
            copy,
        )
        self._build()

    def forget_geometry(self, patch: str | None = None) -> None:
        """Announce a new geometry of ``patch`` (of every patch if None): the patch's geometry
        and forces are dropped, and its next frame sets its geometry, whatever its size.

        Raises:
            UnknownPatchError: ``patch`` is not configured.
        """
        patches = list(self.patch_links) if patch is None else [patch]
        for name in patches:
            self._patch_link(name)
        for name in patches:
            self._geometry.pop(name, None)
            self._taken.pop(name, None)
        self._build()

    def taxel_count(self, patch: str) -> int | None:
        """The taxel count of ``patch``'s geometry, None while it has none."""
        self._patch_link(patch)
        known = self._geometry.get(patch)
        return None if known is None else int(known[0].shape[0])

    def _patch_link(self, patch: str) -> str:
        link = self.patch_links.get(patch)
        if link is None:
            raise UnknownPatchError(
                f"unknown patch {patch!r}; configured: {sorted(self.patch_links)}"
            )
        return link

    def set_forces(self, patch: str, forces: FloatArray, stamp_ns: int) -> None:
        """Hot path: new forces [N] for a patch whose geometry is already set."""
        slot = self._slots.get(patch)
        if slot is None or patch not in self._geometry:
            self._patch_link(patch)
            raise InvalidTaxelData(
                f"patch {patch!r} has no geometry yet: call set_geometry or update first"
            )
        if forces.shape != (slot[1] - slot[0],):
            raise InvalidTaxelData(
                f"patch {patch!r}: {forces.shape} forces for {slot[1] - slot[0]} taxels"
            )
        self._take_forces(patch, forces, slot, stamp_ns)

    def _take_forces(self, patch: str, forces: FloatArray, slot: tuple[int, int, int],
                     stamp_ns: int) -> None:
        """Check a frame's forces [N] (shape already checked), then store them: the range
        (:func:`check_forces`), the stuck skin (:class:`StuckDetector`); with the numba kernel
        one fused pass (:func:`patch_sums.take_frame`) also updates the patch's sums.

        Raises:
            InvalidTaxelData: as check_forces or the stuck detector; nothing is stored.
        """
        c0, c1, row = slot
        if not self._numba:
            previous = self._forces[c0:c1]
            norm2 = check_forces(forces, self.config.max_taxel_force)
            self._stuck.check(patch, norm2, forces, previous, stamp_ns)
            previous[:] = forces
            self._stamps[patch] = stamp_ns
            return
        threshold = self.config.force_threshold
        norm2, unchanged = patch_sums.take_frame(forces, self._forces, self._rows_t, c0, threshold,
                                            self._limit2, self._patch_table, row)
        if not norm2 <= self._limit2:  # names the bad value and raises, or clears the alarm
            check_forces(forces, self.config.max_taxel_force)
            norm2, unchanged = patch_sums.take_frame(forces, self._forces, self._rows_t, c0,
                                                threshold, math.inf, self._patch_table, row)
        # A stuck frame is refused only when unchanged, and an unchanged frame wrote nothing.
        self._stuck.check(patch, norm2, forces, None, stamp_ns, unchanged)
        self._stamps[patch] = stamp_ns

    def update(
        self, patch: str, taxels: TaxelArray, check_geometry: bool = True
    ) -> ContactState:
        """Fold in one frame of ``patch`` and return its link's contact state.

        The patch's first frame (after construction or :meth:`forget_geometry`) sets its
        geometry; a later frame with another taxel count or weighting is refused
        (:class:`GeometryMismatch`), and so is one with other positions, normals or weights
        unless ``check_geometry=False``, which skips that comparison (two array comparisons;
        cost: docs/benchmarks.md, "Contact estimation"). The refusals (NaN/Inf anywhere,
        forces beyond ``max_taxel_force``, an empty cloud) apply to every frame either way,
        except that geometry arrays that are the very objects of the patch's last taken frame
        (read-only, so unchanged) are not checked again (:meth:`_take_geometry`).

        Raises:
            UnknownPatchError: ``patch`` is not configured.
            InvalidTaxelData: the frame is refused (the patch keeps its previous frame).
        """
        link = self._patch_link(patch)
        check_shapes(taxels.positions, taxels.normals, taxels.forces, taxels.weights)
        geometry = (taxels.positions, taxels.normals, taxels.weights)
        known_objects = self._taken.get(patch)
        if known_objects is None or any(
            a is not b for a, b in zip(geometry, known_objects, strict=True)
        ):
            self._take_geometry(patch, taxels, check_geometry)
        return self._take_state(patch, link, taxels.forces, taxels.stamp_ns)

    def update_table(self, patch: str, table: FloatArray, stamp_ns: int,
                     check_geometry: bool = True) -> ContactState:
        """:meth:`update` for a frame given as phri's taxel table: a read-only (N, 7) or (N, 8)
        float array, columns x, y, z [m], normal x, y, z, force [N] (, weight ω) (the layout
        of :mod:`phri_common.taxels`; a decoded message's bytes viewed in place).

        Same states and the same refusals as :meth:`update` on the table's columns; with the
        numba kernel a frame of a patch whose geometry is known (same size, same weighting)
        and ``check_geometry=False`` takes one compiled pass (:func:`patch_sums.take_table`: the
        NaN/Inf test of the geometry, the range and stuck tests of the forces, the sums, the
        link's state); every other frame, and every frame that pass flags, goes through
        :meth:`update`, which takes the geometry or names what is wrong.

        Raises:
            UnknownPatchError, InvalidTaxelData: as :meth:`update`.
        """
        if table.ndim != 2 or table.shape[1] not in (7, 8):
            raise InvalidTaxelData(f"patch {patch!r}: a taxel table has shape (N, 7) or "
                                   f"(N, 8), got {table.shape}")
        weighted = table.shape[1] == 8
        known = self._geometry.get(patch)
        if (not check_geometry and self._numba and known is not None
                and known[0].shape[0] == table.shape[0] and (known[2] is not None) == weighted):
            c0, _, row = self._slots[patch]
            link = self.patch_links[patch]
            i = self._link_index[link]
            out = np.empty((1, patch_sums.STATE_WIDTH))
            total, norm2, unchanged = patch_sums.take_table(
                table, self._forces, self._rows_t, c0, self.config.force_threshold,
                self._limit2, self._patch_table, row, self._groups, self._limit, i, out,
                self._counts)
            if math.isfinite(total) and norm2 <= self._limit2:
                self._stuck.check(patch, norm2, table[:, 6], None, stamp_ns, unchanged)
                self._stamps[patch] = stamp_ns
                return self._link_state(i, out)
        taxels = TaxelArray(table[:, 0:3], table[:, 3:6], table[:, 6],
                            table[:, 7] if weighted else None, self.patch_links.get(patch, ""),
                            stamp_ns)
        return self.update(patch, taxels, check_geometry)

    def _take_state(self, patch: str, link: str, forces: FloatArray,
                    stamp_ns: int) -> ContactState:
        """Take a frame's forces [N] (:meth:`_take_forces`) and return ``link``'s state; with
        the numba kernel in one compiled call (:func:`patch_sums.take_state`) when they are within
        the range (any other frame takes the checked path, which names what is wrong)."""
        i = self._link_index[link]
        slot = self._slots[patch]
        if self._numba:
            out = np.empty((1, patch_sums.STATE_WIDTH))
            norm2, unchanged = patch_sums.take_state(
                forces, self._forces, self._rows_t, slot[0], self.config.force_threshold,
                self._limit2, self._patch_table, slot[2], self._groups, self._limit, i, out,
                self._counts)
            if norm2 <= self._limit2:
                self._stuck.check(patch, norm2, forces, None, stamp_ns, unchanged)
                self._stamps[patch] = stamp_ns
                return self._link_state(i, out)
        self._take_forces(patch, forces, slot, stamp_ns)
        return self._states(i, i + 1)[link]

    def _take_geometry(self, patch: str, taxels: TaxelArray, check_geometry: bool) -> None:
        """Check a frame's geometry values, take them as the patch's geometry if it has none,
        else check they are the patch's (:class:`GeometryMismatch`); remember the frame's
        (read-only) array objects, so a frame handing over the very same objects (a composed
        skin driver passes its layout's arrays every frame) skips these checks: a
        TaxelArray's arrays cannot be written."""
        if not (self._numba and taxels.weights is None
                and math.isfinite(patch_sums.geometry_total(taxels.positions, taxels.normals))):
            check_geometry_values(taxels.positions, taxels.normals, taxels.weights)
        known = self._geometry.get(patch)
        if known is None:
            self.set_geometry(patch, taxels.positions, taxels.normals, taxels.weights)
        else:
            self._check_same_geometry(patch, known, taxels, check_geometry)
        self._taken[patch] = (taxels.positions, taxels.normals, taxels.weights)

    def _check_same_geometry(self, patch: str,
                             known: tuple[FloatArray, FloatArray, FloatArray | None],
                             taxels: TaxelArray, compare: bool) -> None:
        """Raise :class:`GeometryMismatch` unless ``taxels`` has the patch's geometry: the
        same taxel count and weighting always, the same values when ``compare``."""
        expected, received = known[0].shape[0], taxels.positions.shape[0]
        if received != expected:
            raise GeometryMismatch(patch, expected, received, f"a frame of {received} taxels, "
                                   f"the patch's geometry has {expected}")
        if (known[2] is None) != (taxels.weights is None):
            frame, has = ("with", "without") if known[2] is None else ("without", "with")
            raise GeometryMismatch(patch, expected, received, f"a frame {frame} weights, the "
                                   f"patch's geometry is {has} weights")
        if compare and self._geometry_changed(known, taxels):
            raise GeometryMismatch(patch, expected, received, f"a frame of {received} taxels "
                                   "whose positions, normals or weights differ from the "
                                   "patch's geometry")

    @staticmethod
    def _geometry_changed(
        known: tuple[FloatArray, FloatArray, FloatArray | None], taxels: TaxelArray
    ) -> bool:
        return bool(
            not np.array_equal(known[0], taxels.positions)
            or not np.array_equal(known[1], taxels.normals)
            or (known[2] is None) != (taxels.weights is None)
            or (known[2] is not None and not np.array_equal(known[2], taxels.weights))
        )

    def link_state(self, link: str) -> ContactState:
        """Current contact state of ``link`` from its patches' latest frames."""
        if link not in self.links:
            raise KeyError(f"unknown link {link!r}; configured: {sorted(self.links)}")
        i = self._link_index[link]
        return self._states(i, i + 1)[link]

    def estimate(self) -> dict[str, ContactState]:
        """Every link's contact state from its patches' latest frames (eq. 5, 9a, 9b, Ω_i)."""
        return self._states(0, len(self._link_items))

    def _link_sums_numpy(self) -> NDArray[np.float64]:
        """The numpy reference of :func:`contact_estimation.patch_sums.patch_sums` summed per link
        (the tests' oracle): a row per link, ``[Σ rows (force rows × F), min p (3), max p (3),
        count]`` over the union of the link's patches."""
        forces = self._forces
        contacting = np.flatnonzero(forces > self.config.force_threshold)  # ends with sentinel
        gathered = self._rows[:, contacting]
        gathered[_FORCE_ROWS] *= forces[contacting]
        bounds = np.searchsorted(contacting, self._link_starts)
        table = np.concatenate([
            np.add.reduceat(gathered, bounds, axis=1).T,
            np.minimum.reduceat(gathered[_P], bounds, axis=1).T,
            np.maximum.reduceat(gathered[_P], bounds, axis=1).T,
            np.diff(bounds, append=bounds[-1])[:, None],
        ], axis=1)
        return np.ascontiguousarray(table)

    def _states(self, first: int, last: int) -> dict[str, ContactState]:
        """Contact states of links ``first`` … ``last − 1`` from their sums (5), (9a), (9b):
        per patch (numba kernel, kept up to date by every frame) or per link (numpy)."""
        if self._numba:
            sums, groups = self._patch_table, self._groups
        else:
            sums, groups = self._link_sums_numpy(), self._link_rows
        table = np.empty((last - first, patch_sums.STATE_WIDTH))
        patch_sums.link_states(sums, groups, self._limit, first, last, table, self._counts)
        return {self._link_items[i][0]: self._link_state(i, table, i - first)
                for i in range(first, last)}

    def _link_state(self, i: int, table: NDArray[np.float64], k: int = 0) -> ContactState:
        """Link ``i``'s state from row ``k`` of a state table just written by
        :func:`patch_sums.link_states` (taxel count in ``self._counts[i]``); freezes ``table``:
        the state's vectors are read-only views of it, so it must not be reused."""
        table.flags.writeable = False
        link, patches = self._link_items[i]
        stamps = self._stamps
        stamp = stamps[patches[0]] if len(patches) == 1 else max(map(stamps.__getitem__,
                                                                       patches))
        count = int(self._counts[i])
        if count:
            return ContactState.from_frozen_row(link, stamp, True, table[k], count)
        return ContactState.no_contact(link, stamp)


def estimate_contact(
    link: str,
    taxels: TaxelArray,
    config: EstimatorConfig | None = None,
) -> ContactState:
    """One patch's taxels → the contact state of its link (convenience for one-off use)."""
    return ContactEstimator({"patch": link}, config).update("patch", taxels)

