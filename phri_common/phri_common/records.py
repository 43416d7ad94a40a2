"""phri's core value types: one link's contact state and one skin patch's taxel array (pure).

No ROS message package is imported here: the estimator and the controller work on these types
and can be imported, tested and benchmarked without ROS. The message codecs
(:mod:`phri_common.contact`, :mod:`phri_common.taxels`) import these types, never the reverse.

Both types are immutable values: every array they hold is read-only (a writable array handed in
is copied first, so the caller keeps its buffer), and ``==`` compares every field element-wise.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

Vector3 = NDArray[np.float64]
FloatArray = NDArray[np.floating]

CONTACT_VECTORS: tuple[str, ...] = ("center", "force", "torque", "region_min", "region_max")


def is_frozen(array: np.ndarray) -> bool:
    """Whether no numpy array in ``array``'s base chain can write its memory."""
    a: object = array
    while isinstance(a, np.ndarray):
        if a.flags.writeable:
            return False
        a = a.base
    return True


_F64 = np.dtype(np.float64)


def frozen(value: object, shape: tuple[int, ...], what: str, dtype: np.dtype = _F64) -> NDArray:
    """``value`` as a read-only array of ``shape``: no copy if it already is one, else a copy.

    Raises:
        ValueError: the shape differs; the message names ``what`` and both shapes.
    """
    if (type(value) is np.ndarray and value.dtype is dtype and value.shape == shape
            and is_frozen(value)):
        return value
    array: NDArray = np.array(value, dtype=dtype)
    if array.shape != shape:
        raise ValueError(f"{what} must have shape {shape}, got {array.shape}")
    array.flags.writeable = False
    return array


_ZERO3: Vector3 = np.zeros(3)
_ZERO3.flags.writeable = False
_SET = object.__setattr__


class ContactState:
    """One link's contact state (paper Sec. IV-A/B), all vectors in the link frame. Immutable.

    Attributes:
        link: link frame name.
        stamp_ns: acquisition time [ns].
        in_contact: whether any taxel is over the threshold.
        center: contact centre ᶦp_η (5) [m].
        force: resultant force ᶦf_η (9a) on the link [N].
        torque: torque about the centre ᶦτ_η (9b), limited [N·m].
        region_min: lower corner of the contact region Ω_i [m].
        region_max: upper corner of the contact region Ω_i [m].
        taxel_count: number of taxels in contact.

    A plain class with ``__slots__`` rather than a frozen dataclass: the estimator makes three
    per control step, and this one is built in a third of the time.
    """

    __slots__ = ("center", "force", "in_contact", "link", "region_max", "region_min",
                 "stamp_ns", "taxel_count", "torque")
    link: str
    stamp_ns: int
    in_contact: bool
    center: Vector3
    force: Vector3
    torque: Vector3
    region_min: Vector3
    region_max: Vector3
    taxel_count: int

    def __init__(self, link: str, stamp_ns: int, in_contact: bool = False,
                 center: object = _ZERO3, force: object = _ZERO3, torque: object = _ZERO3,
                 region_min: object = _ZERO3, region_max: object = _ZERO3,
                 taxel_count: int = 0) -> None:
        _SET(self, "link", link)
        _SET(self, "stamp_ns", stamp_ns)
        _SET(self, "in_contact", in_contact)
        _SET(self, "taxel_count", taxel_count)
        _SET(self, "center", frozen(center, (3,), "contact state center"))
        _SET(self, "force", frozen(force, (3,), "contact state force"))
        _SET(self, "torque", frozen(torque, (3,), "contact state torque"))
        _SET(self, "region_min", frozen(region_min, (3,), "contact state region_min"))
        _SET(self, "region_max", frozen(region_max, (3,), "contact state region_max"))

    def __setattr__(self, name: str, value: object) -> None:
        raise AttributeError(f"ContactState is immutable: cannot set {name!r}")

    def __delattr__(self, name: str) -> None:
        raise AttributeError(f"ContactState is immutable: cannot delete {name!r}")

    def __reduce__(self) -> tuple[Any, tuple[Any, ...]]:
        """Pickled through the constructor (a worker process gets the same state)."""
        return (ContactState, (self.link, self.stamp_ns, self.in_contact, self.center,
                               self.force, self.torque, self.region_min, self.region_max,
                               self.taxel_count))

    @classmethod
    def from_row(cls, link: str, stamp_ns: int, in_contact: bool, row: object,
                 taxel_count: int) -> ContactState:
        """From the 15 floats centre, force, torque, region_min, region_max (that order): one
        read-only array whose slices become the vectors (the estimator's and codec's path)."""
        return cls.from_frozen_row(link, stamp_ns, in_contact,
                                   frozen(row, (15,), "contact state row"), taxel_count)

    @classmethod
    def from_frozen_row(cls, link: str, stamp_ns: int, in_contact: bool, row: Vector3,
                        taxel_count: int) -> ContactState:
        """As :meth:`from_row` for a ``row`` the caller guarantees to be a float64 array of
        shape (15,) that nothing can write (:func:`is_frozen`); not checked (the check would cost
        a third of the state): the estimator's path, once per link and estimate."""
        state = object.__new__(cls)
        _SET(state, "link", link)
        _SET(state, "stamp_ns", stamp_ns)
        _SET(state, "in_contact", in_contact)
        _SET(state, "taxel_count", taxel_count)
        _SET(state, "center", row[0:3])
        _SET(state, "force", row[3:6])
        _SET(state, "torque", row[6:9])
        _SET(state, "region_min", row[9:12])
        _SET(state, "region_max", row[12:15])
        return state

    @classmethod
    def no_contact(cls, link: str, stamp_ns: int) -> ContactState:
        """The explicit no-contact state: flag false, count 0, every vector zero."""
        state = object.__new__(cls)
        _SET(state, "link", link)
        _SET(state, "stamp_ns", stamp_ns)
        _SET(state, "in_contact", False)
        _SET(state, "taxel_count", 0)
        for name in CONTACT_VECTORS:
            _SET(state, name, _ZERO3)  # read-only, shared
        return state

    def _key(self) -> tuple[object, ...]:
        return (self.link, self.stamp_ns, bool(self.in_contact), self.taxel_count,
                *(tuple(getattr(self, name).tolist()) for name in CONTACT_VECTORS))

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, ContactState):
            return NotImplemented
        return self._key() == other._key()

    def __hash__(self) -> int:
        return hash(self._key())

    def __repr__(self) -> str:
        vectors = ", ".join(f"{n}={getattr(self, n).tolist()}" for n in CONTACT_VECTORS)
        return (f"ContactState(link={self.link!r}, stamp_ns={self.stamp_ns}, "
                f"in_contact={self.in_contact}, {vectors}, taxel_count={self.taxel_count})")


@dataclass(frozen=True, eq=False)
class TaxelArray:
    """One skin patch's taxels at one instant, in the frame of the link the patch is on.

    Attributes:
        positions: (N, 3) taxel centres [m].
        normals: (N, 3) outward unit normals.
        forces: (N,) normal force on each taxel [N].
        weights: (N,) the paper's ω (eq. 5), or ``None`` for all ones.
        frame_id: the link frame the positions are expressed in.
        stamp_ns: acquisition time [ns].
    """

    positions: FloatArray
    normals: FloatArray
    forces: FloatArray
    weights: FloatArray | None
    frame_id: str
    stamp_ns: int

    def __post_init__(self) -> None:
        forces = np.asarray(self.forces)
        if forces.ndim != 1:
            raise ValueError(f"taxel forces must be 1-D, got shape {forces.shape}")
        n = forces.shape[0]
        shapes = {"positions": (n, 3), "normals": (n, 3), "forces": (n,), "weights": (n,)}
        for name, shape in shapes.items():
            value = getattr(self, name)
            if value is None:
                continue
            kind = value.dtype if isinstance(value, np.ndarray) and value.dtype.kind == "f" \
                else _F64
            array = frozen(value, shape, f"taxel {name}", kind)
            if array is not value:
                object.__setattr__(self, name, array)

    @property
    def size(self) -> int:
        """Number of taxels N."""
        return int(self.forces.shape[0])

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, TaxelArray):
            return NotImplemented
        if (self.frame_id, self.stamp_ns) != (other.frame_id, other.stamp_ns):
            return False
        if (self.weights is None) != (other.weights is None):
            return False
        pairs = [(self.positions, other.positions), (self.normals, other.normals),
                 (self.forces, other.forces)]
        if self.weights is not None and other.weights is not None:
            pairs.append((self.weights, other.weights))
        return all(np.array_equal(a, b) for a, b in pairs)

    __hash__ = None  # type: ignore[assignment]  # large arrays: equality, no hashing
