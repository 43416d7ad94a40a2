"""Simulated board ↔ parser/calibration agreement, fault injection, pty transport reconnect.

Waits are bounded by ``WAIT_S`` only so that a stalled machine fails instead of hanging."""

from __future__ import annotations

import itertools
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from skin_driver.calibration import CalibrationConfig, PatchCalibrator
from skin_driver.layout import SkinLayout, rectangular_patch
from skin_driver.protocol import FrameParser
from skin_driver.sim_board import (
    Faults,
    PtyEndpoint,
    SimBoard,
    press_pattern,
    replay_pattern,
    run_boards,
)
from skin_driver.transport import SerialReader

WAIT_S = 60.0
"""Longest wait for something that must happen (a stalled machine); never a measured time."""


def _wait(cond, timeout: float = WAIT_S) -> bool:  # type: ignore[no-untyped-def]
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if cond():
            return True
        time.sleep(0.01)
    return bool(cond())


def test_board_and_driver_calibration_agree() -> None:
    base = rectangular_patch("p", "l", 4, 4)
    rng = np.random.default_rng(0)
    layout = SkinLayout(base.patch, base.link, base.positions, base.normals,
                        gains=rng.uniform(3e-4, 7e-4, 16), offsets=rng.uniform(500, 1500, 16))
    board = SimBoard(2, layout, noise_counts=1.0, seed=1)
    parser = FrameParser()
    cal = PatchCalibrator(16, CalibrationConfig(tare_frames=0, drift_time_constant=0),
                          layout.gains, layout.offsets)
    forces = np.linspace(0.0, 3.0, 16)
    out = None
    for k in range(20):
        for frame in parser.feed(board.frame(forces, k / 500)):
            assert frame.board_id == 2
            out = cal.process(frame.counts, k / 500)
    assert out is not None
    # Count resolution 0.7 mN, noise σ 1 count averaged over 10 frames.
    np.testing.assert_allclose(out, forces, atol=2e-3)


def test_a_noise_bank_keeps_the_noise_and_never_repeats_a_frame() -> None:
    """``noise_bank``: the counts' noise keeps its σ and zero mean, differs between
    consecutive frames (a repeated frame would look stuck to the driver), and the same seed
    gives the same bytes."""
    layout = rectangular_patch("p", "l", 50, 40)
    zero = np.zeros(layout.size)

    offsets = SimBoard(0, layout).offsets

    def frames(seed: int) -> np.ndarray:
        board = SimBoard(0, layout, noise_counts=2.0, seed=seed, noise_bank=8)
        return np.array([board.counts(zero, k / 500) for k in range(200)], dtype=float)

    counts = frames(1)
    noise = counts - offsets
    assert abs(noise.mean()) < 0.05
    assert noise.std() == pytest.approx(np.sqrt(2.0**2 + 1 / 12), rel=0.05)  # σ and rounding
    assert all((a != b).any() for a, b in itertools.pairwise(counts))
    np.testing.assert_array_equal(counts, frames(1))
    assert (counts != frames(2)).any()
    with pytest.raises(ValueError, match="noise_bank"):
        SimBoard(0, layout, noise_bank=-1)


def test_press_pattern_total_force_and_replay() -> None:
    layout = rectangular_patch("p", "l", 10, 10)
    pattern = press_pattern(layout, force=6.0, radius=0.012, period=1.0, duty=0.5)
    on, off = pattern(0.1), pattern(0.7)
    assert on.sum() == pytest.approx(6.0) and np.count_nonzero(on) > 1 and off.sum() == 0.0
    rec = np.arange(12.0).reshape(4, 3)
    replay = replay_pattern(rec, rate=10.0)
    np.testing.assert_array_equal(replay(0.25), rec[2])
    np.testing.assert_array_equal(replay(0.45), rec[0])  # loops


def test_fault_injection_is_seen_by_the_parser() -> None:
    faults = Faults(garbage_rate=0.2, bitflip_rate=0.1, drop_rate=0.1)
    board = SimBoard(0, size=64, faults=faults, seed=3)
    parser = FrameParser()
    for k in range(2000):
        parser.feed(board.frame(np.zeros(64), k / 500))
    parser.feed(bytes(4096))
    c = board.counters
    assert c.garbage_bursts > 300 and c.bitflips > 150 and c.dropped > 150
    # Every intact frame is recovered; every flipped one is rejected and counted as lost.
    assert parser.stats.frames == c.frames
    assert parser.stats.boards[0].dropped == c.dropped + c.bitflips
    assert parser.stats.crc_errors >= c.bitflips * 0.9  # a flipped sync byte is no CRC error


def test_pty_reader_survives_disconnects(tmp_path: Path) -> None:
    link = tmp_path / "skin0"
    faults = Faults(disconnect_every=0.4, disconnect_duration=0.3)
    board = SimBoard(0, size=32, faults=faults, seed=0)
    stop = threading.Event()
    writer = threading.Thread(
        target=run_boards,
        args=(lambda: PtyEndpoint(link), [(board, lambda t: np.zeros(32))], 200.0, stop),
        daemon=True,
    )
    writer.start()
    parser = FrameParser()
    reader = SerialReader(str(link), lambda d, t: parser.feed(d), backoff_initial=0.02,
                          backoff_max=0.1)
    try:
        assert _wait(link.exists)
        reader.start()
        assert _wait(lambda: reader.stats.connects >= 3 and parser.stats.frames > 100)
        assert reader.stats.disconnects >= 2
        assert reader.running
    finally:
        stop.set()
        reader.stop()
        writer.join(5)


def test_cli_writes_frames_into_a_pty_until_sigterm(tmp_path: Path) -> None:
    """``sim_skin_board`` (the console script) sends both boards' frames, with garbage between
    them, into the pty behind ``--link`` until SIGTERM; then it reports what it sent and exits
    with 0."""
    link = tmp_path / "cli"
    exe = Path(sys.executable).with_name("sim_skin_board")
    proc = subprocess.Popen(
        [str(exe), "--link", str(link), "--taxels", "16", "--rate", "200", "--boards", "2",
         "--garbage-rate", "0.1"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    parser = FrameParser()
    reader = SerialReader(str(link), lambda d, _: parser.feed(d), backoff_initial=0.02,
                          backoff_max=0.05)
    reader.start()
    try:
        assert _wait(lambda: set(parser.stats.boards) == {0, 1} and parser.stats.frames > 100)
        proc.send_signal(signal.SIGTERM)
        out, err = proc.communicate(timeout=WAIT_S)
    finally:
        reader.stop()
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 0, err
    assert "2 board(s) at 200 Hz" in out and "sim_skin_board: sent " in out, out
    assert parser.stats.resyncs > 0  # the garbage was there, and skipped


def test_counts_are_offset_plus_force_over_gain_plus_noise_rounded_and_clipped() -> None:
    """count = clip(rint(offset + (F + drift·t)/gain + noise), 0, 65535); NaN → 0 and ±inf →
    the range's ends (written out here independently of the in-place implementation)."""
    from skin_driver.layout import rectangular_patch

    layout = rectangular_patch("p", "l", 10, 12)
    board = SimBoard(0, layout, noise_counts=2.0, drift_rate=0.01, seed=3)
    noise = np.random.default_rng(3)  # the board's stream: same seed, same draws
    forces = np.random.default_rng(9).normal(0.0, 3.0, (50, layout.size))
    forces[::7, 5], forces[::7, 6], forces[::7, 7], forces[:, 8] = np.nan, np.inf, -np.inf, 1e9
    for k, f in enumerate(forces):
        t = 0.002 * k
        value = board.offsets + (f + 0.01 * t) * (1.0 / board.gains) + noise.normal(0, 2.0, f.size)
        value = np.where(np.isnan(value), 0.0, value)
        expected = np.clip(np.rint(value), 0, 65535).astype(np.uint16)
        np.testing.assert_array_equal(board.counts(f, t), expected)
        assert np.array_equal(f[:5], forces[k, :5])  # the caller's array is not modified


def test_cli_serves_frames_over_tcp_with_listen() -> None:
    """``sim_skin_board --listen 0`` (an Ethernet board) prints the ``socket://`` URL it
    serves; a driver's reader on that URL receives its frames whole."""
    exe = Path(sys.executable).with_name("sim_skin_board")
    proc = subprocess.Popen([str(exe), "--listen", "127.0.0.1:0", "--taxels", "10000",
                             "--rate", "100"], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True)
    parser = FrameParser()
    reader = None
    try:
        assert proc.stdout is not None
        line = proc.stdout.readline()
        url = line.split(" on ")[1].split()[0]
        assert url.startswith("socket://127.0.0.1:"), line
        reader = SerialReader(url, lambda d, _: parser.feed(d), backoff_initial=0.02,
                              backoff_max=0.05)
        reader.start()
        assert _wait(lambda: parser.stats.frames > 20)
        assert parser.stats.resyncs == 0 and parser.stats.frame_crc_errors == 0
    finally:
        if reader is not None:
            reader.stop()
        proc.send_signal(signal.SIGTERM)
        proc.communicate(timeout=WAIT_S)
    assert proc.returncode == 0
