"""Checks every skin frame passes before the estimator takes it (pure numpy).

The refusals of docs/contact_estimation.md ("Bad input"): non-finite forces, positions, normals
or weights; a force beyond the skin's rated range; arrays of mismatched size; a geometry other
than the patch's; a patch nobody configured; a touched patch whose forces repeat bit for bit
(a stuck skin). Each refusal is an exception naming the patch and the field. The checks are cheap
enough for every frame: a sum test per array (a BLAS product, fTf for the forces, 1ᵀA for
positions and normals); only a test that fails triggers the exact element-wise check.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.floating]

DEFAULT_MAX_TAXEL_FORCE = 1000.0
"""Default bound on one taxel's force [N]. A 7.5 mm taxel (56 mm²) at 1000 N is under 18 MPa,
beyond any skin's rated range (the default calibration saturates at 0.0005 N/count × 64,535
counts ≈ 32 N) and beyond any contact with a person; a larger value is a corrupted reading."""

MAX_TAXEL_FORCE_RANGE = (1.0, 1.0e6)
"""Allowed range of ``max_taxel_force`` [N]."""

class InvalidTaxelData(ValueError):
    """A patch frame holds NaN/Inf values or arrays of inconsistent size; it was refused."""


class GeometryMismatch(InvalidTaxelData):
    """A frame's geometry differs from its patch's (learnt or set); it was refused.

    Attributes:
        patch: the patch.
        expected: the patch's taxel count.
        received: the frame's taxel count.
    """

    def __init__(self, patch: str, expected: int, received: int, what: str) -> None:
        super().__init__(
            f"patch {patch!r}: {what}: refused (a patch's geometry changes only when "
            "announced: forget_geometry, the node's ~/reset_geometry)"
        )
        self.patch, self.expected, self.received = patch, expected, received


class UnknownPatchError(KeyError):
    """A frame arrived for a patch the estimator was not configured with."""


def check_shapes(
    positions: FloatArray, normals: FloatArray, forces: FloatArray, weights: FloatArray | None
) -> int:
    n = forces.shape[0] if forces.ndim == 1 else -1
    if (
        n < 0
        or positions.shape != (n, 3)
        or normals.shape != (n, 3)
        or (weights is not None and weights.shape != (n,))
    ):
        raise InvalidTaxelData(
            f"taxel arrays of mismatched size: positions {positions.shape}, normals "
            f"{normals.shape}, forces {forces.shape}, weights "
            f"{None if weights is None else weights.shape}"
        )
    if n == 0:
        raise InvalidTaxelData("empty taxel cloud: a patch has at least one taxel")
    return n


_ONES: dict[tuple[int, np.dtype], FloatArray] = {}


def _ones(n: int, dtype: np.dtype) -> FloatArray:
    """A cached vector of n ones (the summing vector of the sum tests)."""
    ones = _ONES.get((n, dtype))
    if ones is None:
        if len(_ONES) >= 64:
            _ONES.clear()
        ones = _ONES[(n, dtype)] = np.ones(n, dtype=dtype)
    return ones


def check_forces(forces: FloatArray, max_force: float) -> float:
    """Refuse NaN/Inf forces and forces beyond ``±max_force`` [N]; return ‖f‖² [N²].

    Cheap test first: ``‖f‖² = fᵀf`` (one BLAS dot). Every |fᵢ| ≤ ‖f‖, so ‖f‖ ≤ ``max_force``
    proves every force finite and within the range; NaN/Inf or an overflow fail the test. Only
    then does the element-wise check run, which clears a false alarm (many forces that are
    each within range) or names what is wrong.

    Raises:
        InvalidTaxelData: how many forces are bad, the worst value and the allowed range.
    """
    with np.errstate(all="ignore"):
        norm2 = float(forces @ forces)
    if norm2 <= max_force * max_force:
        return norm2
    n = forces.shape[0]
    nonfinite = int(np.count_nonzero(~np.isfinite(forces)))
    if nonfinite:
        raise InvalidTaxelData(f"{nonfinite} of {n} taxel forces are NaN or infinite")
    f_min, f_max = float(forces.min()), float(forces.max())
    if -max_force <= f_min and f_max <= max_force:
        return norm2
    over = int(np.count_nonzero(np.abs(forces) > max_force))
    worst = f_max if abs(f_max) >= abs(f_min) else f_min
    raise InvalidTaxelData(
        f"{over} of {n} taxel forces beyond the skin's rated range (max_taxel_force): "
        f"{worst:.6g} N, allowed [{-max_force:g}, {max_force:g}] N"
    )


def check_geometry_values(
    positions: FloatArray, normals: FloatArray, weights: FloatArray | None
) -> None:
    """Refuse NaN/Inf positions, normals or weights.

    Cheap test first: the sum of every element, ``1ᵀ P 1 + 1ᵀ N 1 (+ Σ ω)`` (one BLAS call per
    (N, 3) array, fast on the strided float32 columns of a decoded message, where a plain
    ``sum`` is about three times slower); a finite sum proves every element finite. Only a sum
    that is not finite triggers the element-wise check, which clears a false alarm (an
    overflow of finite values) or names the field.

    Raises:
        InvalidTaxelData: naming the field and how many taxels are bad.
    """
    n = positions.shape[0]
    ones = _ones(n, positions.dtype)
    with np.errstate(all="ignore"):
        total = float(np.add.reduce(ones @ positions + ones @ normals))
        if weights is not None:
            total += float(np.add.reduce(weights))
    if math.isfinite(total):
        return
    for name, arr in (("position", positions), ("normal", normals), ("weight", weights)):
        if arr is not None and not np.isfinite(arr).all():
            bad = int(np.count_nonzero(~np.isfinite(arr).reshape(n, -1).all(axis=1)))
            raise InvalidTaxelData(f"{bad} of {n} taxel {name}s are NaN or infinite")


class StuckDetector:
    """A stuck skin: a touched patch (‖f‖ > 0) whose forces repeat bit for bit for longer than
    ``timeout`` [s] of frame stamps. A real skin's ADC noise never repeats a loaded frame
    exactly, so this is a dead board or driver replaying its last frame: a fault, not a licence
    to push (design §8). Its frames are refused until they change; downstream the link's contact
    state then goes stale and the controller stops.

    Cheap on the hot path: ‖f‖², which the range check computes anyway, is the fingerprint; the
    arrays are compared only when it repeats.
    """

    def __init__(self, timeout: float) -> None:
        self.timeout_ns = int(timeout * 1e9)
        self._fingerprint: dict[str, float] = {}
        self._since: dict[str, int] = {}

    def check(self, patch: str, norm2: float, forces: FloatArray, previous: FloatArray | None,
              stamp_ns: int, unchanged: bool | None = None) -> None:
        """Take ``patch``'s new frame (‖f‖² = ``norm2``) against its ``previous`` forces
        (``unchanged``: their element-wise equality where the caller has computed it; then
        ``previous`` is not read and may be None).

        Raises:
            InvalidTaxelData: the patch has been stuck for longer than the timeout.
        """
        if unchanged is None:
            unchanged = (norm2 == self._fingerprint.get(patch) and previous is not None
                         and np.array_equal(forces, previous))
        if norm2 == 0.0 or norm2 != self._fingerprint.get(patch) or not unchanged:
            self._fingerprint[patch] = norm2
            self._since[patch] = stamp_ns
            return
        stuck_for = stamp_ns - self._since[patch]
        if stuck_for > self.timeout_ns:
            raise InvalidTaxelData(
                f"patch {patch!r} stuck: its loaded frame has repeated bit for bit for "
                f"{stuck_for * 1e-9:.3f} s (stuck_timeout {self.timeout_ns * 1e-9:g} s); refused"
            )
