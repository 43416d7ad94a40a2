"""The safe stop: a detected sensor lie stops the robot with an exact zero command (pure).

A plausibility verdict on the controller's side (:mod:`~wholebody_controller.skin_torque_check`:
a skin gain far off, a skin silent while the joints feel a contact) *trips* the stop. While it is
tripped, every control cycle publishes an exact zero on every output — the QP is not run, so
neither the tasks nor the q_dance band constraint (22) can command anything (a band-keeping
correction of a few mrad/s is still a drive on a lie) — the tasks are reset once, and
``/diagnostics`` reports ERROR with the reason. It stays tripped until an operator resets it
(``~/reset``, which also resets the tasks): a skin that lied once is not trusted again because
it stopped lying.

The skin-alone verdicts of contact estimation (:mod:`contact_estimation.plausibility`: dead
region, frozen patch) reach the controller as a missing contact state: the link's input goes
stale and the freshness rules command the same exact zero, until the patch is plausible again.
"""

from __future__ import annotations

from dataclasses import dataclass, field


@dataclass
class SafeStop:
    """The latch (module docstring).

    Attributes:
        reasons: kind → message of every verdict since the last :meth:`clear` (empty: not
            tripped), in the order they came.
        trips: how many times it was tripped since start-up.
    """

    reasons: dict[str, str] = field(default_factory=dict)
    trips: int = 0
    entered: bool = False
    """Whether :meth:`holds` has already reported this trip's first cycle."""

    @property
    def active(self) -> bool:
        """Whether the robot must stand (an exact zero command)."""
        return bool(self.reasons)

    def trip(self, kind: str, message: str) -> bool:
        """Record a verdict; whether it is new (not already tripped for ``kind``)."""
        new = kind not in self.reasons
        self.reasons[kind] = message
        if new:
            self.trips += 1
        return new

    def holds(self) -> tuple[bool, bool]:
        """Once per cycle: (whether the robot must stand, whether this is the trip's first
        cycle — the caller resets the tasks once)."""
        if not self.active:
            self.entered = False
            return False, False
        first, self.entered = not self.entered, True
        return True, first

    def clear(self) -> list[str]:
        """Reset (``~/reset``); the kinds that were cleared."""
        kinds = list(self.reasons)
        self.reasons.clear()
        return kinds

    def summary(self) -> str:
        """One line for the log and diagnostics ('' when not tripped)."""
        return "; ".join(f"{k}: {m}" for k, m in self.reasons.items())
