"""Driver state → ``diagnostic_msgs/DiagnosticStatus`` (pure conversions, no rclpy).

One status for the port (connection, byte-level errors) and one per board/patch (rate, drops,
masked taxels, silence). Levels: ERROR when the port is down or a board is silent (its patch is
not being published), WARN when bytes arrive without an intact frame for longer than the limit,
when frames were lost or corrupted during the last period or taxels are masked, OK otherwise.
"""

from __future__ import annotations

from dataclasses import dataclass

from diagnostic_msgs.msg import DiagnosticStatus, KeyValue

from skin_driver.calibration import CalibrationStatus


@dataclass(frozen=True)
class PortSnapshot:
    """Port-level counters at one instant (totals since start unless stated)."""

    url: str
    connected: bool
    connects: int
    disconnects: int
    failed_opens: int
    bytes_read: int
    crc_errors: int
    bad_headers: int
    false_lengths: int
    resyncs: int
    discarded_bytes: int
    unknown_board_frames: int
    new_errors: int
    """CRC errors + bad headers + false lengths + resyncs during the last period."""
    last_error: str
    unframed_s: float = 0.0
    """How long bytes have been arriving without an intact frame [s]."""
    unframed_bytes: int = 0
    """Bytes received since the last intact frame (counted while ``unframed_s`` > 0)."""
    unframed_limit_s: float = float("inf")
    """WARN when ``unframed_s`` exceeds this [s] (the node's ``silence_timeout``)."""


@dataclass(frozen=True)
class BoardSnapshot:
    """One board/patch at one instant."""

    board_id: int
    patch: str
    link: str
    taxels: int
    rate_hz: float
    frames: int
    published: int
    dropped: int
    new_drops: int
    restarts: int
    size_mismatches: int
    new_size_mismatches: int
    clock_restarts: int
    silent: bool
    last_frame_age_s: float
    calibration: CalibrationStatus
    wrong_size_taxels: int = 0
    """Taxel count of the last frame refused for not matching the layout (0: none)."""


def _kv(key: str, value: object) -> KeyValue:
    if isinstance(value, float):
        return KeyValue(key=key, value=f"{value:.4g}")
    return KeyValue(key=key, value=str(value))


def port_status(p: PortSnapshot) -> DiagnosticStatus:
    """Status of the serial port."""
    if not p.connected:
        level, message = DiagnosticStatus.ERROR, f"port not open: {p.last_error or 'connecting'}"
    elif p.unframed_s > p.unframed_limit_s:
        level = DiagnosticStatus.WARN
        message = f"{p.unframed_bytes} bytes in {p.unframed_s:.1f} s without an intact frame"
    elif p.new_errors:
        level, message = DiagnosticStatus.WARN, f"{p.new_errors} corrupted frames or resyncs"
    else:
        level, message = DiagnosticStatus.OK, "connected"
    values = [
        _kv("connected", p.connected),
        _kv("connects", p.connects),
        _kv("disconnects", p.disconnects),
        _kv("failed_opens", p.failed_opens),
        _kv("bytes_read", p.bytes_read),
        _kv("crc_errors", p.crc_errors),
        _kv("bad_headers", p.bad_headers),
        _kv("false_lengths", p.false_lengths),
        _kv("resyncs", p.resyncs),
        _kv("discarded_bytes", p.discarded_bytes),
        _kv("bytes_without_frame", p.unframed_bytes),
        _kv("unknown_board_frames", p.unknown_board_frames),
        _kv("last_error", p.last_error),
    ]
    return DiagnosticStatus(
        level=level,
        name=f"skin_driver: port {p.url}",
        message=message,
        hardware_id=p.url,
        values=values,
    )


def board_status(b: BoardSnapshot, url: str) -> DiagnosticStatus:
    """Status of one board and the patch it feeds."""
    cal = b.calibration
    if b.silent:
        level = DiagnosticStatus.ERROR
        message = f"silent for {b.last_frame_age_s:.2f} s: not publishing"
    elif not cal.tared:
        level, message = DiagnosticStatus.WARN, "taring"
    elif b.new_drops or b.new_size_mismatches:
        level = DiagnosticStatus.WARN
        message = f"{b.new_drops} frames dropped"
        if b.new_size_mismatches:
            message += (f", {b.new_size_mismatches} frames of the wrong size refused "
                        f"({b.wrong_size_taxels} taxels, the layout has {b.taxels})")
    elif cal.dead or cal.saturated:
        level = DiagnosticStatus.WARN
        message = f"{cal.dead} taxels masked, {cal.saturated} saturated"
    else:
        level, message = DiagnosticStatus.OK, f"{b.rate_hz:.0f} Hz"
    values = [
        _kv("board_id", b.board_id),
        _kv("patch", b.patch),
        _kv("link", b.link),
        _kv("taxels", b.taxels),
        _kv("rate_hz", b.rate_hz),
        _kv("frames", b.frames),
        _kv("published", b.published),
        _kv("dropped", b.dropped),
        _kv("sequence_restarts", b.restarts),
        _kv("size_mismatches", b.size_mismatches),
        _kv("wrong_size_taxels", b.wrong_size_taxels),
        _kv("clock_restarts", b.clock_restarts),
        _kv("last_frame_age_s", b.last_frame_age_s),
        _kv("tared", cal.tared),
        _kv("masked_taxels", cal.dead),
        _kv("stuck_taxels", cal.stuck),
        _kv("saturated_taxels", cal.saturated),
        _kv("touched_at_tare", cal.touched_at_tare),
        _kv("max_baseline_N", cal.max_baseline),
    ]
    return DiagnosticStatus(
        level=level,
        name=f"skin_driver: {b.patch} (board {b.board_id})",
        message=message,
        hardware_id=f"{url}#{b.board_id}",
        values=values,
    )
