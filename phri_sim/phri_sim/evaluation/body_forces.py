"""Contact forces between the robot and the person against ISO/TS 15066 limits (pure, no rclpy).

Two parts:

* :class:`PersonRobotForces` reads, from a MuJoCo state, the force on every body part of the
  simulated person (one part per person geom: :data:`PERSON_PART_REGIONS`) and on every robot link
  (a body that is neither the world nor the person's): per contact between a person geom and a
  robot geom the magnitude of its full contact force (normal and friction, ‖f‖ [N]), summed over
  the contacts of the part / of the link. The sum of magnitudes bounds the resultant from above,
  so a limit checked on it holds for the resultant too.
* :class:`ForceLimitTracker` reduces a force series per name to the two numbers ISO/TS 15066
  bounds (``docs/phri_sim.md``, "Body-region limits"):

  - **peak force** F_peak = max_t F(t), held to the region's *transient* limit;
  - **sustained force** F_sus = max_t min{F(s) : t − 0.5 s ≤ s ≤ t} (the largest force present in
    every sample of some 0.5 s window), held to the region's *quasi-static* limit. So a force
    above the quasi-static limit for less than :data:`SUSTAINED_WINDOW` is a transient contact
    and allowed up to the transient limit; one above it for 0.5 s or longer is a violation.

Body-part → region mapping (:data:`PERSON_PART_REGIONS`): the waist → ``abdomen``, the chest →
``chest``, each hand → ``hand_finger`` (Table A.2 regions of :mod:`phri_common.iso15066`).
"""

from __future__ import annotations

from collections import deque
from collections.abc import Collection, Mapping
from dataclasses import dataclass, field
from typing import Any

import mujoco
import numpy as np

from phri_common.iso15066 import BODY_REGIONS, BodyRegion

SUSTAINED_WINDOW = 0.5
"""A force held this long [s] or longer is quasi-static (ISO/TS 15066: transient < 0.5 s)."""

PERSON_PART_REGIONS: dict[str, str] = {
    "person_waist": "abdomen",
    "person_abdomen": "abdomen",
    "person_chest": "chest",
    "person_head": "skull_forehead",
    "person_left_hand": "hand_finger",
    "person_right_hand": "hand_finger",
}
"""Person geom (= body part) → ISO/TS 15066 body region of :data:`BODY_REGIONS`."""


def part_region(part: str) -> BodyRegion:
    """The ISO/TS 15066 region of a person body part.

    Raises:
        KeyError: the part is not mapped; the message names the mapped parts.
    """
    try:
        return BODY_REGIONS[PERSON_PART_REGIONS[part]]
    except KeyError:
        raise KeyError(f"person body part {part!r} has no ISO/TS 15066 region; mapped: "
                       f"{sorted(PERSON_PART_REGIONS)}") from None


class PersonRobotForces:
    """Per-part and per-link contact forces of a MuJoCo state (module docstring).

    Args:
        model: the scene.
        person_geoms: ids of the person's geoms (each one that collides must be named and
            mapped in :data:`PERSON_PART_REGIONS`: KeyError otherwise).

    Attributes:
        parts: the person's body parts (geom names), in geom order.
        links: every robot link with collision geometry (body names).
    """

    def __init__(self, model: mujoco.MjModel, person_geoms: Collection[int]) -> None:
        self.model = model
        self._part = {int(g): str(model.geom(int(g)).name) for g in person_geoms
                      if model.geom_contype[g] or model.geom_conaffinity[g]}
        for name in self._part.values():
            part_region(name)
        # Robot links: bodies with collision geometry that are neither the world (floor) nor
        # the person's.
        self._link = {
            g: str(model.body(int(model.geom_bodyid[g])).name) for g in range(model.ngeom)
            if g not in self._part and int(model.geom_bodyid[g]) != 0
            and (model.geom_contype[g] or model.geom_conaffinity[g])
        }
        self.parts = tuple(dict.fromkeys(self._part.values()))
        self.links = tuple(dict.fromkeys(self._link.values()))
        self._wrench = np.zeros(6)

    def read(self, data: mujoco.MjData) -> tuple[dict[str, float], dict[str, float],
                                                  set[tuple[str, str]]]:
        """(force per touched part [N], force per touched link [N], touching (part, link)
        pairs) at the state of ``data`` (after a step or ``mj_forward``)."""
        parts: dict[str, float] = {}
        links: dict[str, float] = {}
        pairs: set[tuple[str, str]] = set()
        for i in range(data.ncon):
            con = data.contact[i]
            g1, g2 = int(con.geom1), int(con.geom2)
            part = self._part.get(g1) or self._part.get(g2)
            link = self._link.get(g1) or self._link.get(g2)
            if part is None or link is None:
                continue
            mujoco.mj_contactForce(self.model, data, i, self._wrench)
            f = float(np.linalg.norm(self._wrench[:3]))
            parts[part] = parts.get(part, 0.0) + f
            links[link] = links.get(link, 0.0) + f
            pairs.add((part, link))
        return parts, links, pairs


@dataclass
class _Series:
    peak: float = 0.0
    sustained: float = 0.0
    window: deque[tuple[float, float]] = field(default_factory=deque)
    start: float = 0.0


class ForceLimitTracker:
    """Peak and sustained force per name from samples F(t) (module docstring).

    Args:
        window: the sustained-force window [s] (:data:`SUSTAINED_WINDOW`).
    """

    def __init__(self, window: float = SUSTAINED_WINDOW) -> None:
        if not window > 0.0:
            raise ValueError(f"window {window} refused: allowed (0, inf) s")
        self.window = window
        self._series: dict[str, _Series] = {}
        self._start: float | None = None
        self._names: tuple[str, ...] = ()
        self._idle: set[str] = set()
        """Names whose last sample was 0 N (their window: that one sample)."""
        self._previous = 0.0
        """Time [s] of the previous sample."""

    def add(self, t: float, forces: Mapping[str, float], names: Collection[str] = ()) -> None:
        """One sample at time ``t`` [s] (increasing): ``forces`` [N] per touched name; every name
        seen before, or listed in ``names``, that is missing reads 0 N.

        A name that read 0 N last time and again now is not visited: a zero sample empties its
        window down to that one sample and changes neither peak nor sustained force (both are
        ≥ 0), so only the time of its last zero sample is needed, and that is the previous call's
        time when the name next reads a force (same numbers as visiting it every sample)."""
        if self._start is None:
            self._start = t
        if names != self._names:
            self._names = tuple(names)
            for name in self._names:
                self._new_series(name)
        series, idle = self._series, self._idle
        for name, value in forces.items():
            s = series.get(name) or self._new_series(name)
            if name in idle:  # its window: the zero sample of the previous call
                idle.discard(name)
                s.window = deque([(self._previous, 0.0)])
            self._sample(s, t, float(value))
            if value == 0.0:
                idle.add(name)
        for name, s in series.items():
            if name not in idle and name not in forces:
                self._sample(s, t, 0.0)
                idle.add(name)
        self._previous = t

    def _new_series(self, name: str) -> _Series:
        """The series of ``name``, created (empty, from the first sample's time) if new."""
        s = self._series.get(name)
        if s is None:
            s = self._series[name] = _Series(start=self._start or 0.0)
        return s

    def _sample(self, s: _Series, t: float, f: float) -> None:
        """Add F(t) = ``f`` [N] to one series (module docstring)."""
        s.peak = max(s.peak, f)
        # Monotonic deque: window minimum of the samples in [t − window, t].
        while s.window and s.window[-1][1] >= f:
            s.window.pop()
        s.window.append((t, f))
        while s.window[0][0] < t - self.window - 1e-9:
            s.window.popleft()
        if t - s.start >= self.window - 1e-9:
            s.sustained = max(s.sustained, s.window[0][1])

    def peak(self, name: str) -> float:
        """Largest force seen for ``name`` [N] (0 if never touched)."""
        s = self._series.get(name)
        return s.peak if s is not None else 0.0

    def sustained(self, name: str) -> float:
        """Largest force held through a whole window for ``name`` [N] (module docstring)."""
        s = self._series.get(name)
        return s.sustained if s is not None else 0.0


def limit_report(region: BodyRegion | None, peak: float, sustained: float) -> dict[str, object]:
    """One body part's / link's row: forces [N], the region's limits [N] and ``ok`` (peak ≤
    transient limit and sustained ≤ quasi-static limit; no region → ok)."""
    if region is None:
        return {"peak_force": peak, "sustained_force": sustained, "region": None, "ok": True}
    ok = peak <= region.transient and sustained <= region.quasi_static
    return {
        "peak_force": peak,
        "sustained_force": sustained,
        "region": region.name,
        "quasi_static_limit": region.quasi_static,
        "transient_limit": region.transient,
        "ok": bool(ok),
    }


def limit_failures(report: Mapping[str, Any]) -> dict[str, Any]:
    """The rows of an ``iso15066`` metrics block (``person`` and ``robot_links``) that are not
    ``ok``, by name (empty: every part and link within its limits)."""
    rows = {**report["person"], **report["robot_links"]}
    return {name: row for name, row in rows.items() if not row["ok"]}
