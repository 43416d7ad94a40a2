"""The skin boards on the wire: the simulator's skin samples → protocol-v1 frames → the real
skin driver code (pure, no rclpy).

With the skin driver in the loop (bridge parameter ``skin_driver``, ``phri sim --skin-driver``),
every skin sample of every patch leaves the simulation as a frame of the documented serial
protocol (``docs/skin_protocol.md``) from the patch's simulated board
(:class:`phri_sim.world.skin_sensor.PatchSensor`: skin_driver's ``SimBoard`` with the sensor model's
gain errors, zero offsets, noise and dead taxels; board id = the patch's index, sequence +1 per
frame, ``board_time_us`` = the sample's simulation time). The frames of all boards of a sample
go as one byte chunk (one hub port) through :class:`skin_driver.stream.SkinStream`: the
driver's parser, calibration with the nominal layout, tare, moving average (window 10, the
paper's) and drift compensation. What comes out is what the simulator publishes on
``skin/<patch>/taxels``, exactly where ``skin_driver_node`` publishes on the robot.

Tare: the driver tares on its first ``tare_frames`` frames, before the scenario starts, from
boards nobody touches (:meth:`SkinLink.tare`), as on the robot, where the driver starts before
the person approaches.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from phri_sim.world.skin_sensor import PatchSensor
from skin_driver.calibration import CalibrationConfig, FloatArray
from skin_driver.stream import SkinStream


class SkinLink:
    """The simulated boards of the patches (:class:`~phri_sim.world.skin_sensor.PatchSensor`) on
    one port, read by the driver code.

    Args:
        sensors: patch → its board.
        config: the driver's calibration settings (default: the node's default parameters).
    """

    def __init__(self, sensors: Mapping[str, PatchSensor],
                 config: CalibrationConfig | None = None) -> None:
        self.config = config or CalibrationConfig()
        self.sensors = dict(sensors)
        # The driver knows the nominal layouts (no gain errors, no dead taxels declared).
        self.stream = SkinStream({s.board_id: s.layout for s in self.sensors.values()},
                                 self.config)
        self.frames_sent = 0
        self.bytes_sent = 0

    def send(self, forces: Mapping[str, FloatArray], t: float) -> dict[str, FloatArray]:
        """One sample: every given patch's true taxel forces [N] as its board's frame at board
        time ``t`` [s], all in one chunk through the driver; returns patch → calibrated forces
        [N] (none while taring)."""
        chunk = b"".join(self.sensors[patch].frame(f, t) for patch, f in forces.items())
        self.frames_sent += len(forces)
        self.bytes_sent += len(chunk)
        frames = self.stream.feed(chunk, t)
        return {f.patch: f.forces for f in frames}

    def tare(self, period: float) -> None:
        """Run the driver's start-up tare: frames with no force on any patch every ``period``
        [s], at times before 0, until every board is tared (``tare_frames`` frames)."""
        frames = self.config.tare_frames
        zeros = {patch: np.zeros(s.layout.size) for patch, s in self.sensors.items()}
        for k in range(frames):
            self.send(zeros, (k - frames) * period)
        if not self.stream.tared:
            raise RuntimeError("skin driver: tare incomplete after tare_frames frames")
