"""Board clock → ROS time: stamp each frame with the time its board sampled it (pure, no rclpy).

Every protocol-v1 frame carries ``board_time_us``, the board's own clock at sampling [µs,
wraps at 2³²] (docs/skin_protocol.md). The host only sees when the bytes *arrived*, which is
the sampling time plus a transfer and scheduling delay d ≥ d_min that varies from frame to frame
and grows without bound when frames queue up (a stalled read delivers a burst of frames in one
chunk). So the driver maps the board clock to the node clock:

    stamp = b + o,      b = unwrapped board time [ns],   o ≈ min over recent frames of (a − b)

where a is the arrival time of the chunk that completed the frame. ``a − b = o_true + d`` for
every frame, so its lower envelope is the offset plus the smallest delay: frames stamped this
way keep the board's exact spacing (2 ms at 500 Hz), whatever the arrival jitter or bursts,
and are never later than their arrival. The envelope follows drift between the two clocks:
a smaller ``a − b`` lowers o at once, and o rises by at most ``drift_rate`` per second of board
time when ``a − b`` only grows (a board clock slower than the host's; crystals differ by
≤ 100 ppm, ``drift_rate`` is 1000 ppm).

The mapping starts again (o = a − b of the current frame) when the board clock goes backwards
(a reset), or when ``a − b`` exceeds o by more than ``reanchor_after`` (the board clock jumped,
or frames are that late); the first frames after a start may be stamped late by their delay
until a faster frame lowers o.
"""

from __future__ import annotations

from dataclasses import dataclass

BOARD_CLOCK_MODULO_US = 1 << 32
"""The board clock wraps at 2³² µs (about 71.6 min)."""


@dataclass
class BoardClock:
    """Per-board mapping of ``board_time_us`` to the node clock (module docstring).

    Args:
        drift_rate: largest rate at which the offset may rise [s/s] (≥ the clocks' drift).
        reanchor_after: an ``a − b`` this far above the offset restarts the mapping [s].

    Attributes:
        restarts: times the mapping started again (board clock reset or jump).
    """

    drift_rate: float = 1e-3
    reanchor_after: float = 1.0
    restarts: int = 0
    _last_us: int | None = None
    _board_ns: int = 0
    _offset_ns: int = 0

    def __post_init__(self) -> None:
        if not 0.0 <= self.drift_rate < 1.0:
            raise ValueError(f"drift_rate [s/s] refused value {self.drift_rate}: allowed [0, 1)")
        if not self.reanchor_after > 0.0:
            raise ValueError(
                f"reanchor_after [s] refused value {self.reanchor_after}: allowed (0, inf)"
            )

    def stamp(self, board_time_us: int, arrival_ns: int) -> int:
        """Acquisition time [ns, node clock] of a frame sampled at ``board_time_us``.

        ``arrival_ns`` is the node clock when the chunk that completed the frame was read.
        """
        if self._last_us is None:
            return self._anchor(board_time_us, arrival_ns, count=False)
        step_us = (board_time_us - self._last_us) % BOARD_CLOCK_MODULO_US
        if step_us >= BOARD_CLOCK_MODULO_US // 2:  # went backwards: the board restarted
            return self._anchor(board_time_us, arrival_ns, count=True)
        self._last_us = board_time_us
        self._board_ns += step_us * 1000
        lag_ns = arrival_ns - self._board_ns
        risen_ns = self._offset_ns + int(step_us * 1000 * self.drift_rate)
        if lag_ns - risen_ns > self.reanchor_after * 1e9:
            return self._anchor(board_time_us, arrival_ns, count=True)
        self._offset_ns = min(risen_ns, lag_ns)
        return self._board_ns + self._offset_ns

    def _anchor(self, board_time_us: int, arrival_ns: int, count: bool) -> int:
        self.restarts += int(count)
        self._last_us = board_time_us
        self._board_ns = board_time_us * 1000
        self._offset_ns = arrival_ns - self._board_ns
        return arrival_ns


__all__ = ["BOARD_CLOCK_MODULO_US", "BoardClock"]
