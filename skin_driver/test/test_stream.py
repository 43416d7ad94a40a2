"""SkinStream: the driver's pipeline without the node — bytes of simulated boards in,
calibrated frames out, with the tare and the moving average of the calibration."""

from __future__ import annotations

import numpy as np
import pytest

from skin_driver.calibration import CalibrationConfig
from skin_driver.layout import rectangular_patch
from skin_driver.protocol import encode_frame
from skin_driver.sim_board import SimBoard
from skin_driver.stream import SkinStream

A = rectangular_patch("patch_a", "link_a", 4, 5)
B = rectangular_patch("patch_b", "link_b", 3, 3)
CONFIG = CalibrationConfig(tare_frames=20, filter_window=10, drift_time_constant=0.0)


def _stream() -> tuple[SkinStream, SimBoard, SimBoard]:
    stream = SkinStream({3: A, 7: B}, CONFIG)
    return stream, SimBoard(3, A, noise_counts=0.0), SimBoard(7, B, noise_counts=0.0)


def test_no_output_while_taring_then_every_frame_of_every_board() -> None:
    stream, a, b = _stream()
    for k in range(CONFIG.tare_frames):
        out = stream.feed(a.frame(np.zeros(A.size), k * 0.002)
                          + b.frame(np.zeros(B.size), k * 0.002), k * 0.002)
        assert out == []
    assert stream.tared
    out = stream.feed(a.frame(np.zeros(A.size), 1.0) + b.frame(np.zeros(B.size), 1.0), 1.0)
    assert [(f.board_id, f.patch) for f in out] == [(3, "patch_a"), (7, "patch_b")]
    assert stream.counters[3].taring == CONFIG.tare_frames


def test_a_step_rises_through_the_moving_average_of_ten_frames() -> None:
    """The paper's filter: a 2 N step reaches k/10 of its value in the k-th frame."""
    stream, a, _ = _stream()
    t = 0.0
    for _ in range(CONFIG.tare_frames + 10):  # tare, then fill the window with zeros
        stream.feed(a.frame(np.zeros(A.size), t), t)
        t += 0.002
    pressed = np.zeros(A.size)
    pressed[5] = 2.0
    seen = []
    for _ in range(12):
        (frame,) = stream.feed(a.frame(pressed, t), t)
        seen.append(frame.forces[5])
        assert np.all(np.delete(frame.forces, 5) == 0.0)
        t += 0.002
    expected = [2.0 * min(k, 10) / 10 for k in range(1, 13)]
    np.testing.assert_allclose(seen, expected, atol=0.0005)  # one count


def test_wrong_size_and_unknown_boards_are_counted_not_calibrated() -> None:
    stream, _, _ = _stream()
    data = encode_frame(3, 0, np.full(A.size + 1, 1000)) + encode_frame(9, 0, np.full(4, 1000))
    assert stream.feed(data, 0.0) == []
    assert stream.counters[3].size_mismatches == 1
    assert stream.counters[3].wrong_size == A.size + 1
    assert stream.unknown_board_frames == 1
    # The next good frame is used (taken by the tare here), the layout's size unchanged.
    assert stream.feed(encode_frame(3, 1, np.full(A.size, 1000)), 0.002) == []
    assert stream.counters[3].sequence.frames == 1 and stream.counters[3].taring == 1
    assert stream.layouts[3].size == A.size


def test_sequence_gaps_are_counted_per_board() -> None:
    stream, _, _ = _stream()
    counts = np.full(A.size, 1000)
    stream.feed(encode_frame(3, 0, counts) + encode_frame(3, 4, counts), 0.0)
    assert stream.counters[3].sequence.dropped == 3


def test_split_chunks_give_the_same_frames() -> None:
    s1, a1, _ = _stream()
    s2, a2, _ = _stream()
    rng = np.random.default_rng(1)
    data = b"".join(a1.frame(rng.uniform(0, 1, A.size), k * 0.002) for k in range(30))
    whole = s1.feed(data, 0.0)
    pieces = [f for i in range(0, len(data), 7) for f in s2.feed(data[i:i + 7], 0.0)]
    assert [f.sequence for f in whole] == [f.sequence for f in pieces]
    for f, g in zip(whole, pieces, strict=True):
        np.testing.assert_array_equal(f.forces, g.forces)
    assert a2.sequence == 0 and len(whole) == 30 - CONFIG.tare_frames


@pytest.mark.parametrize("window", [1, 10])
def test_filter_window_is_the_configs(window: int) -> None:
    config = CalibrationConfig(tare_frames=0, filter_window=window)
    stream = SkinStream({0: A}, config)
    board = SimBoard(0, A, noise_counts=0.0)
    f = np.zeros(A.size)
    f[0] = 1.0
    (frame,) = stream.feed(board.frame(f, 0.0), 0.0)
    assert frame.forces[0] == pytest.approx(1.0, abs=0.0005)  # a first frame is its own mean
    (frame,) = stream.feed(board.frame(np.zeros(A.size), 0.002), 0.002)
    assert frame.forces[0] == pytest.approx(0.0 if window == 1 else 0.5, abs=0.0005)
