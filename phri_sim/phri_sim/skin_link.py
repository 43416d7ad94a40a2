"""The skin boards on the wire: the simulator's raw counts → protocol-v1 frames → the real
skin driver code (pure, no rclpy).

With the skin driver in the loop (bridge parameter ``skin_driver``, ``phri sim --skin-driver``),
every skin sample of every patch leaves the simulation as the raw counts of the sensor model
(:mod:`phri_sim.sensor_model`), is encoded as a frame of the documented serial protocol
(``docs/skin_protocol.md``, :func:`skin_driver.protocol.encode_frame`; board id = the patch's
index, sequence +1 per frame, ``board_time_us`` = the sample's simulation time), and the frames
of all boards of a sample go as one byte chunk (one hub port) through
:class:`skin_driver.stream.SkinStream`: the driver's parser, tare, calibration, moving average
(window 10, the paper's) and drift compensation. What comes out is what the simulator publishes
on ``skin/<patch>/taxels``, exactly where ``skin_driver_node`` publishes on the robot.

Tare: the driver tares on its first ``tare_frames`` frames, before the scenario starts, from
boards nobody touches (:meth:`SkinLink.tare`), as on the robot, where the driver starts before
the person approaches.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence

import numpy as np
from numpy.typing import NDArray

from skin_driver.calibration import CalibrationConfig, FloatArray
from skin_driver.layout import SkinLayout
from skin_driver.protocol import encode_frame
from skin_driver.stream import SkinStream

Counts = NDArray[np.uint16]


class SkinLink:
    """The simulated boards of ``layouts`` (in order: board id = index) on one port.

    Args:
        layouts: the patches' layouts, in board-id order.
        config: the driver's calibration settings (default: the node's default parameters).
    """

    def __init__(self, layouts: Sequence[SkinLayout],
                 config: CalibrationConfig | None = None) -> None:
        self.config = config or CalibrationConfig()
        self.boards = {layout.patch: board for board, layout in enumerate(layouts)}
        self.stream = SkinStream(dict(enumerate(layouts)), self.config)
        self._sequence = dict.fromkeys(self.boards, 0)
        self.frames_sent = 0
        self.bytes_sent = 0

    def send(self, counts: Mapping[str, Counts], stamp_ns: int) -> dict[str, FloatArray]:
        """One sample: every given patch's counts as a frame stamped ``stamp_ns`` [ns] (≥ 0 or
        negative during the tare), through the driver; returns patch → calibrated forces [N]
        (none while taring)."""
        chunk = bytearray()
        board_time_us = stamp_ns // 1000
        for patch, c in counts.items():
            seq = self._sequence[patch]
            chunk += encode_frame(self.boards[patch], seq, c, board_time_us)
            self._sequence[patch] = seq + 1
        self.frames_sent += len(counts)
        self.bytes_sent += len(chunk)
        frames = self.stream.feed(chunk, stamp_ns * 1e-9)
        return {f.patch: f.forces for f in frames}

    def tare(self, untouched: Callable[[str], Counts], period_ns: int) -> None:
        """Run the driver's start-up tare: frames of ``untouched(patch)`` (the counts of the
        patch with no force on it) every ``period_ns`` [ns], stamped before 0, until every
        board is tared (``tare_frames`` frames; nothing when that is 0)."""
        frames = self.config.tare_frames
        for k in range(frames):
            self.send({p: untouched(p) for p in self.boards}, (k - frames) * period_ns)
        if not self.stream.tared:
            raise RuntimeError("skin driver: tare incomplete after tare_frames frames")
