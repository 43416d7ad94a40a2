"""Input freshness of the controller node: may this control cycle use its inputs? (pure, no rclpy)

The node reports when each input arrived (:meth:`InputFreshness.contact_arrived`,
:meth:`~InputFreshness.joints_arrived`, :meth:`~InputFreshness.odom_arrived`) and asks
:meth:`~InputFreshness.check` once per cycle; a stale verdict means a zero command (design §8).
Times are the node clock [s]: wall time, or simulation time under ``use_sim_time``.

Rules (documented in ``docs/wholebody_controller.md``, section "Input freshness"):

F1. Contact timeout: the latest contact state of *every* link arrived at most ``contact_timeout``
    ago (0 ≤ now − t ≤ timeout; an age equal to the timeout is still fresh).
F2. Joint timeout, oldest joint: every tracked arm joint was last reported at most
    ``joint_state_timeout`` ago; the oldest joint decides, so joint states that cover only some
    joints (partial coverage) leave the others to age.
F3. Odometry timeout: the latest odometry arrived at most ``odom_timeout`` ago.
F4. Never received: an input that has not arrived since start-up is stale (arrival time −∞).
F5. Clock jumped back: an input that arrived after ``now`` (a simulation reset, a system-time
    step) belongs to another timeline and is stale until it arrives again; for the joints the
    newest joint counts too.
F6. Reason order: contacts, then joints, then odometry; the contact reason names every stale link
    in the order of ``links``.
F7. Reset on becoming stale: :meth:`~InputFreshness.check` sets ``became_stale`` once when the
    inputs go from fresh to stale (the node then resets the tasks and warns), neither at start-up
    (never fresh yet) nor again while they stay stale.
F8. Recovery: the first check with every input fresh again is fresh.
F9. Refused input: an input the node refused as bad (non-finite, physically impossible: a contact
    force above ``max_contact_force``, a joint outside its limits, an odometry jump) counts as
    never received until its next valid message — the cycle after a refusal commands zero and
    resets the tasks (F7), the next good message recovers (F8).
"""

from __future__ import annotations

import math
from collections.abc import Collection, Mapping, Sequence
from dataclasses import dataclass
from types import MappingProxyType

NEVER = -math.inf
"""Arrival time of an input that has not arrived yet [s]."""

STALE_CONTACTS = "stale contact states"
STALE_JOINTS = "stale joint states"
STALE_ODOMETRY = "stale odometry"
#: Every reason a stale verdict can give (the contact reason is followed by ": <links>").
REASONS: tuple[str, ...] = (STALE_CONTACTS, STALE_JOINTS, STALE_ODOMETRY)


@dataclass(frozen=True)
class FreshnessConfig:
    """Input timeouts [s] (node parameters of the same names; ranges in ``parameters.py``)."""

    contact_timeout: float
    joint_state_timeout: float
    odom_timeout: float

    def __post_init__(self) -> None:
        for name in ("contact_timeout", "joint_state_timeout", "odom_timeout"):
            value = getattr(self, name)
            if not (isinstance(value, float | int) and math.isfinite(value) and value > 0.0):
                raise ValueError(f"{name} = {value!r} s: must be a finite number > 0")


@dataclass(frozen=True)
class Verdict:
    """The answer of :meth:`InputFreshness.check` for one control cycle."""

    reason: str | None
    """Why the inputs cannot be used, or ``None`` when every input is fresh."""
    became_stale: bool
    """Fresh at the previous check, stale now (F7): reset the tasks and warn."""


def within(now: float, arrival: float, timeout: float) -> bool:
    """0 ≤ now − arrival ≤ timeout [s]: arrived, not in the future (F5), not too old (F1–F4)."""
    return 0.0 <= now - arrival <= timeout


def _require_time(now: float) -> float:
    if not math.isfinite(now):
        raise ValueError(f"arrival time now = {now!r} s: must be finite")
    return now


def _require_names(what: str, names: Sequence[str]) -> tuple[str, ...]:
    out = tuple(names)
    if not out or len(set(out)) != len(out):
        raise ValueError(f"{what} = {list(out)}: must be non-empty and without repeats")
    return out


class InputFreshness:
    """Arrival times of the controller's inputs and the freshness rules F1–F8 (module docstring).

    Args:
        links: skin links whose contact states the controller needs (parameter ``links``).
        joints: arm joints whose positions it needs (the command joint order).
        config: the timeouts; may be replaced later (run-time parameter change).

    Raises:
        ValueError: ``links`` or ``joints`` empty or with repeats.
    """

    def __init__(self, links: Sequence[str], joints: Sequence[str],
                 config: FreshnessConfig) -> None:
        self.config = config
        self._contact_time = dict.fromkeys(_require_names("links", links), NEVER)
        self._joints = _require_names("joints", joints)
        self._joint_time = [NEVER] * len(self._joints)
        self._odom_time = NEVER
        self._stale = True  # nothing received yet (F4); not "became stale" (F7)

    # -- arrivals ------------------------------------------------------------------------------
    def contact_arrived(self, link: str, now: float) -> None:
        """A valid contact state of ``link`` arrived at ``now`` [s].

        Raises:
            ValueError: ``link`` is not one of ``links``, or ``now`` is not finite.
        """
        if link not in self._contact_time:
            raise ValueError(f"link = {link!r}: not one of {list(self._contact_time)}")
        self._contact_time[link] = _require_time(now)

    def joints_arrived(self, names: Collection[str], now: float) -> None:
        """A valid joint state naming ``names`` arrived at ``now`` [s]; untracked names are
        ignored, tracked joints it does not name keep their older time (F2)."""
        _require_time(now)
        times = self._joint_time
        for i, joint in enumerate(self._joints):
            if joint in names:
                times[i] = now

    def odom_arrived(self, now: float) -> None:
        """Valid odometry arrived at ``now`` [s]."""
        self._odom_time = _require_time(now)

    # -- refusals (F9) --------------------------------------------------------------------------
    def contact_refused(self, link: str) -> None:
        """A contact state of ``link`` was refused: stale until the next valid one (F9)."""
        if link not in self._contact_time:
            raise ValueError(f"link = {link!r}: not one of {list(self._contact_time)}")
        self._contact_time[link] = NEVER

    def joints_refused(self, names: Collection[str]) -> None:
        """A joint state naming ``names`` was refused: those joints are stale until reported
        valid again (F9); a refused message whose names are unreadable should pass all joints."""
        times = self._joint_time
        for i, joint in enumerate(self._joints):
            if joint in names:
                times[i] = NEVER

    def odom_refused(self) -> None:
        """Odometry was refused: stale until the next valid message (F9)."""
        self._odom_time = NEVER

    # -- queries -------------------------------------------------------------------------------
    @property
    def contact_time(self) -> Mapping[str, float]:
        """Arrival time of each link's latest contact state [s] (read-only view; −∞: never)."""
        return MappingProxyType(self._contact_time)

    @property
    def joint_time(self) -> tuple[float, ...]:
        """Arrival time of each joint's latest position [s], in ``joints`` order (−∞: never)."""
        return tuple(self._joint_time)

    @property
    def odom_time(self) -> float:
        """Arrival time of the latest odometry [s] (−∞: never)."""
        return self._odom_time

    def all_joints_received(self) -> bool:
        """Every tracked joint has been reported at least once (however long ago)."""
        return NEVER not in self._joint_time

    def stale_reason(self, now: float) -> str | None:
        """Why the inputs cannot be used at ``now`` [s] (F1–F6), or ``None`` when all are fresh."""
        config = self.config
        timeout = config.contact_timeout
        stale_links = [link for link, t in self._contact_time.items()
                       if not within(now, t, timeout)]
        if stale_links:
            return f"{STALE_CONTACTS}: {', '.join(stale_links)}"
        times = self._joint_time
        if not within(now, min(times), config.joint_state_timeout) or now < max(times):
            return STALE_JOINTS
        if not within(now, self._odom_time, config.odom_timeout):
            return STALE_ODOMETRY
        return None

    def check(self, now: float) -> Verdict:
        """The verdict for the control cycle at ``now`` [s] (F1–F8); call once per cycle."""
        reason = self.stale_reason(now)
        became_stale = reason is not None and not self._stale
        self._stale = reason is not None
        return Verdict(reason, became_stale)


__all__ = ["NEVER", "REASONS", "STALE_CONTACTS", "STALE_JOINTS", "STALE_ODOMETRY",
           "FreshnessConfig", "InputFreshness", "Verdict", "within"]

