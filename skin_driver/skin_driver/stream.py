"""In-process skin driver: protocol-v1 bytes in, calibrated frames out (pure, no rclpy).

:class:`SkinStream` is what ``skin_driver_node`` does between the serial port and its
publishers, without the port, the node or the clock: the bytes go through the
:class:`~skin_driver.protocol.FrameParser`, every intact frame of a configured board through
that board's :class:`~skin_driver.calibration.PatchCalibrator` (gain/offset, tare, moving
average, drift compensation, masking). The simulator feeds it the byte stream of its simulated
boards (``phri_sim.skin_link``), so the real driver code sits in the simulated loop.

Differences from the node, by design: the calibrator's time is the caller's ``t`` (the
simulation's clock, so a run is deterministic) instead of the host's monotonic clock, and there
is no silence detection or diagnostics topic (the caller sees every frame it fed).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

from skin_driver.calibration import CalibrationConfig, FloatArray, PatchCalibrator
from skin_driver.layout import SkinLayout
from skin_driver.protocol import MAX_TAXELS, BoardSequence, FrameParser


@dataclass(frozen=True)
class CalibratedFrame:
    """One frame after calibration.

    Attributes:
        board_id: sending board.
        patch: the board's patch (from its layout).
        sequence: the frame's sequence number.
        board_time_us: board clock at sampling [µs].
        forces: (N,) normal forces [N], ≥ 0.
    """

    board_id: int
    patch: str
    sequence: int
    board_time_us: int
    forces: FloatArray


@dataclass
class StreamCounters:
    """Per-board bookkeeping of the frames accepted (dropped = sequence gaps)."""

    sequence: BoardSequence = field(default_factory=BoardSequence)
    size_mismatches: int = 0
    """Frames refused because their taxel count differs from the layout's."""
    wrong_size: int = 0
    """Taxel count of the last of them (0: none)."""
    taring: int = 0
    """Frames taken by the tare (no output)."""


class SkinStream:
    """Bytes of one port (one or several boards) → calibrated frames (module docstring).

    Args:
        layouts: board id → the layout of its patch.
        config: calibration settings (the driver's parameters).
        max_taxels: the parser's bound on a frame's taxel count.
    """

    def __init__(self, layouts: Mapping[int, SkinLayout], config: CalibrationConfig,
                 max_taxels: int = MAX_TAXELS) -> None:
        self.layouts = dict(layouts)
        self.parser = FrameParser(max_taxels)
        self.calibrators = {
            board: PatchCalibrator(layout.size, config, layout.gains, layout.offsets,
                                   layout.dead)
            for board, layout in self.layouts.items()
        }
        self.counters = {board: StreamCounters() for board in self.layouts}
        self.unknown_board_frames = 0

    @property
    def tared(self) -> bool:
        """Every board's start-up tare is complete."""
        return all(c.tared for c in self.calibrators.values())

    def feed(self, data: bytes | bytearray | memoryview, t: float) -> list[CalibratedFrame]:
        """Parse ``data`` and calibrate the frames it completes, at time ``t`` [s] (the
        calibrator's drift and stuck-taxel clock). Frames of unknown boards or of the wrong
        size are counted and skipped; frames taken by a tare give no output."""
        out: list[CalibratedFrame] = []
        for frame in self.parser.feed(data):
            layout = self.layouts.get(frame.board_id)
            if layout is None:
                self.unknown_board_frames += 1
                continue
            counters = self.counters[frame.board_id]
            if frame.counts.shape[0] != layout.size:
                counters.size_mismatches += 1
                counters.wrong_size = frame.counts.shape[0]
                continue
            counters.sequence.observe(frame.sequence)
            forces = self.calibrators[frame.board_id].process(frame.counts, t)
            if forces is None:
                counters.taring += 1
                continue
            out.append(CalibratedFrame(frame.board_id, layout.patch, frame.sequence,
                                       frame.board_time_us, forces))
        return out
