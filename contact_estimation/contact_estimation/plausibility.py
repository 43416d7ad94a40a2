"""Is a patch's skin telling the truth? Checks on the skin alone (pure numpy).

The frame checks (:mod:`~contact_estimation.frame_checks`) refuse what cannot be a reading at all
(NaN, beyond the rated range, a loaded frame repeating bit for bit). A skin can also lie with
readings that each look fine. One such lie is visible in the skin's own statistics (a dead
region); another, a frozen frame with fresh noise, only makes a patch look still:

* **Dead region** (:class:`DeadRegionDetector`): a live taxel always shows noise (the skin
  driver's premise for masking a stuck ADC channel, ``stuck_time``), so a taxel whose force has
  not changed by a single bit for ``dead_time`` [s] is *silent* — a dead taxel, a torn trace, a
  masked channel, a board or cable gone (then the whole patch reads a constant 0 N). A patch
  with more than ``max_dead_fraction`` of its taxels silent is a dead region: a contact there
  would not be seen, and one on its edge is read too light and off-centre.
* **Still** (:class:`FrozenDetector`): a driver that replays its last frame behind a noisy
  analogue stage (or adds its own noise) passes the bit-identical stuck check, and reads like a
  contact held still: a touched link whose contact force and contact centre stay within
  ``frozen_force_ratio`` of their mean and ``frozen_center_range`` [m] over a whole block of
  ``frozen_window`` [s] of touched frames is *still*. Stillness alone is no evidence of a lie: a
  partner holding still on a well-followed link reads still for minutes (the waltz's steady
  hold, the motionless baseline's upper arm), and on the skin alone a constant contact plus the
  skin's noise cannot be told from a replayed frame plus noise. So a still link is reported
  (diagnostics WARN), never refused here; the evidence that the contact must have changed is
  the joints': the controller refuses a still skin whose contact the external joint torques
  see change (``wholebody_controller.skin_torque_check``, "skin frozen"). A frozen patch whose
  untouched taxels replay 0 N is refused here too, as a dead region. A block is decided when
  it is complete (every ``frozen_window`` of touched frames; an untouched frame starts a new
  one).

A patch with a dead region is *implausible*: its frames are refused (:class:`SkinImplausible`,
an :class:`~contact_estimation.frame_checks.InvalidTaxelData`) — counted, reported ERROR on
diagnostics, no contact state published — so the controller's contact input goes stale and it
commands an exact zero (its input freshness rules). The verdict clears by itself when the
statistics are plausible again: the silent taxels show noise again (fewer than the fraction).
A still verdict clears with a complete block of touched frames that varies again, or a
release.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from contact_estimation.frame_checks import InvalidTaxelData

FloatArray = NDArray[np.floating]


class SkinImplausible(InvalidTaxelData):
    """A patch's readings are implausible (a dead region); its frames are refused.

    Attributes:
        patch: the patch.
        kind: ``dead_region``.
    """

    def __init__(self, patch: str, kind: str, message: str) -> None:
        super().__init__(f"patch {patch!r} {kind.replace('_', ' ')}: {message}; refused")
        self.patch, self.kind = patch, kind


@dataclass(frozen=True)
class PlausibilityConfig:
    """Settings of the skin-alone checks (module docstring).

    Attributes:
        dead_time: a taxel unchanged this long is silent [s] (0 = no dead-region check).
        max_dead_fraction: largest share of silent taxels a patch may have [-].
        frozen_window: length of a block of touched frames [s] (0 = no stillness report).
        frozen_force_ratio: a block whose contact force range is below this fraction of its
            mean … [-]
        frozen_center_range: … and whose contact centre moves less than this on every axis is
            still [m].
        min_force: a frame is touched for the stillness report when its contact force reaches this
            [N].
    """

    dead_time: float = 1.0
    max_dead_fraction: float = 0.25
    frozen_window: float = 2.0
    frozen_force_ratio: float = 0.05
    frozen_center_range: float = 2e-3
    min_force: float = 1.0

    def __post_init__(self) -> None:
        checks = (("dead_time", 0.0, 60.0), ("max_dead_fraction", 0.0, 1.0),
                  ("frozen_window", 0.0, 60.0), ("frozen_force_ratio", 0.0, 1.0),
                  ("frozen_center_range", 0.0, 1.0), ("min_force", 0.0, 1e4))
        for name, low, high in checks:
            value = getattr(self, name)
            if not (math.isfinite(value) and low <= value <= high):
                raise ValueError(f"{name} refused value {value!r}: allowed [{low:g}, {high:g}]")


class DeadRegionDetector:
    """Silent taxels per patch (module docstring, "Dead region").

    Per frame: one comparison with the previous frame and one with the silence deadline over
    the patch's taxels (cost: docs/benchmarks.md, "Contact estimation").
    """

    def __init__(self, config: PlausibilityConfig) -> None:
        self.config = config
        self._last: dict[str, FloatArray] = {}
        self._changed: dict[str, NDArray[np.int64]] = {}
        self.silent: dict[str, int] = {}
        """Silent taxels of each patch in its latest frame."""

    def forget(self, patch: str | None = None) -> None:
        """Drop the history of ``patch`` (every patch: ``None``), e.g. with its geometry."""
        for table in (self._last, self._changed, self.silent):
            if patch is None:
                table.clear()
            else:
                table.pop(patch, None)

    def check(self, patch: str, forces: FloatArray, stamp_ns: int) -> None:
        """Take ``patch``'s accepted frame ``forces`` [N] stamped ``stamp_ns``.

        Raises:
            SkinImplausible: more than ``max_dead_fraction`` of its taxels are silent.
        """
        dead_ns = int(self.config.dead_time * 1e9)
        if dead_ns <= 0:
            return
        last = self._last.get(patch)
        if last is None or last.shape != forces.shape:
            self._last[patch] = np.array(forces, dtype=np.float64)
            self._changed[patch] = np.full(forces.shape, stamp_ns, dtype=np.int64)
            self.silent[patch] = 0
            return
        changed = self._changed[patch]
        np.copyto(changed, stamp_ns, where=forces != last)
        last[:] = forces
        silent = int(np.count_nonzero(changed <= stamp_ns - dead_ns))
        self.silent[patch] = silent
        if silent > self.config.max_dead_fraction * forces.shape[0]:
            raise SkinImplausible(
                patch, "dead_region", f"{silent} of {forces.shape[0]} taxels have not changed "
                f"for {self.config.dead_time:g} s (a live taxel shows noise; allowed "
                f"{100 * self.config.max_dead_fraction:g} %: plausibility_dead_fraction)")


@dataclass
class _Block:
    start_ns: int = 0
    frames: int = 0
    f_min: float = math.inf
    f_max: float = -math.inf
    f_sum: float = 0.0
    c_min: tuple[float, float, float] = (math.inf, math.inf, math.inf)
    c_max: tuple[float, float, float] = (-math.inf, -math.inf, -math.inf)


class FrozenDetector:
    """Still contacts per link (module docstring, "Still"): running minimum and maximum of the
    contact force and centre over a block, O(1) per frame. Reports; never refuses."""

    def __init__(self, config: PlausibilityConfig) -> None:
        self.config = config
        self._blocks: dict[str, _Block] = {}
        self.frozen: dict[str, str] = {}
        """The verdict of each link's last complete block ('' = varying, else why it is
        still)."""

    def forget(self, key: str | None = None) -> None:
        """Drop the block and verdict of ``key`` (every one: ``None``)."""
        for table in (self._blocks, self.frozen):
            if key is None:
                table.clear()
            else:
                table.pop(key, None)

    def check(self, patch: str, force: float, center: tuple[float, float, float],
              in_contact: bool, stamp_ns: int) -> str:
        """Take the contact state of ``patch``'s link after one of its accepted frames: its
        force magnitude [N], centre [m] (link frame), whether touched.

        Returns:
            Why the link's last complete block of touched frames was still ('' = it varied,
            or the link is released): a report, not a refusal (module docstring).
        """
        window_ns = int(self.config.frozen_window * 1e9)
        if window_ns <= 0:
            self.frozen.pop(patch, None)
            return ""
        block = self._blocks.get(patch)
        if not in_contact or force < self.config.min_force:
            self._blocks[patch] = _Block(start_ns=stamp_ns)
            self.frozen[patch] = ""
            return ""
        if block is None or block.frames == 0:
            block = self._blocks[patch] = _Block(start_ns=stamp_ns)
        block.frames += 1
        block.f_min, block.f_max = min(block.f_min, force), max(block.f_max, force)
        block.f_sum += force
        block.c_min = (min(block.c_min[0], center[0]), min(block.c_min[1], center[1]),
                       min(block.c_min[2], center[2]))
        block.c_max = (max(block.c_max[0], center[0]), max(block.c_max[1], center[1]),
                       max(block.c_max[2], center[2]))
        if stamp_ns - block.start_ns >= window_ns:
            self.frozen[patch] = self._verdict(block)
            self._blocks[patch] = _Block()
        return self.frozen.get(patch, "")

    def _verdict(self, block: _Block) -> str:
        """Why a complete block is still ('' = it is not)."""
        mean = block.f_sum / block.frames
        ratio = (block.f_max - block.f_min) / mean
        moved = max(hi - lo for lo, hi in zip(block.c_min, block.c_max, strict=True))
        cfg = self.config
        if ratio < cfg.frozen_force_ratio and moved < cfg.frozen_center_range:
            return (f"its contact force stayed within {100 * ratio:.2f} % of {mean:.3g} N and its "
                    f"centre within {1e3 * moved:.3f} mm for {cfg.frozen_window:g} s of contact "
                    f"(plausibility_frozen_window); not refused: the controller checks a still "
                    f"skin against the joints")
        return ""
