"""Protocol v1: encoder/parser contract and hypothesis fuzzing of the streaming parser."""

from __future__ import annotations

import itertools
import struct
import zlib

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from skin_driver.protocol import (
    HEADER_SIZE,
    MAX_TAXELS,
    SYNC,
    FrameParser,
    encode_frame,
    frame_size,
)

MAX_T = 40  # small frames keep the fuzzing fast; the code paths are the same
SETTINGS = settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])


def _crc16_ccitt_false(data: bytes) -> int:
    """Bitwise reference CRC-16/CCITT-FALSE (poly 0x1021, init 0xFFFF), as in the spec."""
    crc = 0xFFFF
    for byte in data:
        crc ^= byte << 8
        for _ in range(8):
            crc = ((crc << 1) ^ 0x1021) if crc & 0x8000 else (crc << 1)
            crc &= 0xFFFF
    return crc


def test_frame_layout_matches_the_specification() -> None:
    counts = np.array([0, 1, 0xABCD, 65535], dtype=np.uint16)
    data = encode_frame(board_id=7, sequence=0x1234, counts=counts, board_time_us=0xDEADBEEF)
    assert len(data) == 16 + 2 * 4 + 4 == frame_size(4)
    assert data[0:2] == b"\xa5\x5a"
    assert data[2] == 1 and data[3] == 1 and data[4] == 7 and data[5] == 0
    assert data[6:8] == b"\x34\x12"  # little-endian sequence
    assert data[8:10] == b"\x04\x00"
    assert data[10:14] == b"\xef\xbe\xad\xde"
    assert struct.unpack("<H", data[14:16])[0] == _crc16_ccitt_false(data[:14])
    assert data[16:24] == b"\x00\x00\x01\x00\xcd\xab\xff\xff"
    assert struct.unpack("<I", data[24:28])[0] == zlib.crc32(data[:24])
    # The published check value of CRC-16/CCITT-FALSE pins the reference itself.
    assert _crc16_ccitt_false(b"123456789") == 0x29B1


@pytest.mark.parametrize(
    ("kwargs", "what"),
    [
        ({"board_id": 256}, "board_id"),
        ({"counts": np.zeros(0)}, "counts"),
        ({"counts": np.zeros(MAX_TAXELS + 1)}, "counts"),
        ({"counts": np.array([70000])}, "counts"),
    ],
)
def test_encoder_refuses_out_of_range(kwargs: dict, what: str) -> None:
    args = {"board_id": 0, "sequence": 0, "counts": np.zeros(3)}
    args.update(kwargs)
    with pytest.raises(ValueError, match=what):
        encode_frame(**args)


@st.composite
def frames(draw: st.DrawFn) -> tuple[int, int, np.ndarray, bytes]:
    board = draw(st.integers(0, 255))
    seq = draw(st.integers(0, 65535))
    n = draw(st.integers(1, MAX_T))
    counts = np.array(draw(st.lists(st.integers(0, 65535), min_size=n, max_size=n)), np.uint16)
    return board, seq, counts, encode_frame(board, seq, counts, board_time_us=seq * 2000)


def _chunks(data: bytes, cuts: list[int]) -> list[bytes]:
    points = sorted({c % (len(data) + 1) for c in cuts})
    edges = [0, *points, len(data)]
    return [data[a:b] for a, b in itertools.pairwise(edges)]


@SETTINGS
@given(frame=frames(), cuts=st.lists(st.integers(0, 10_000), max_size=8))
def test_any_chunking_returns_the_frame(frame: tuple, cuts: list[int]) -> None:
    board, seq, counts, data = frame
    parser = FrameParser(MAX_T)
    out = [f for chunk in _chunks(data, cuts) for f in parser.feed(chunk)]
    assert len(out) == 1
    assert (out[0].board_id, out[0].sequence, out[0].board_time_us) == (
        board, seq, (seq * 2000) % 2**32)
    np.testing.assert_array_equal(out[0].counts, counts)
    assert parser.buffered == 0 and parser.stats.resyncs == 0


@SETTINGS
@given(data=st.binary(max_size=4000), cuts=st.lists(st.integers(0, 4000), max_size=20))
def test_random_bytes_never_raise_and_memory_stays_bounded(data: bytes, cuts: list[int]) -> None:
    parser = FrameParser(MAX_T)
    for chunk in _chunks(data, cuts):
        parser.feed(chunk)
        assert parser.buffered < parser.max_frame_size
    assert parser.stats.bytes_in == len(data)


@SETTINGS
@given(
    items=st.lists(
        st.tuples(frames(), st.binary(max_size=80), st.sampled_from(["intact", "flip", "cut"]),
                  st.integers(0, 10_000)),
        min_size=1,
        max_size=25,
    ),
    cuts=st.lists(st.integers(0, 100_000), max_size=30),
    garbage_syncs=st.integers(0, 3),
)
def test_every_intact_frame_is_recovered_from_garbage_and_bit_flips(
    items: list, cuts: list[int], garbage_syncs: int
) -> None:
    stream = bytearray()
    intact: list[tuple[int, int, bytes]] = []
    corrupted: list[tuple[int, int, bytes]] = []
    for (board, seq, counts, data), garbage, kind, where in items:
        # Garbage salted with sync bytes exercises false starts.
        stream += garbage + SYNC * garbage_syncs
        if kind == "intact":
            stream += data
            intact.append((board, seq, counts.tobytes()))
        elif kind == "flip":
            buf = bytearray(data)
            bit = where % (len(buf) * 8)
            buf[bit // 8] ^= 1 << (bit % 8)
            stream += buf
            corrupted.append((board, seq, counts.tobytes()))
        else:  # a frame cut short (unplug mid-frame)
            stream += data[: where % len(data)]
    # Padding so that a false header promising a long frame is completed and rejected.
    stream += bytes(frame_size(MAX_T))
    parser = FrameParser(MAX_T)
    got = []
    for chunk in _chunks(bytes(stream), cuts):
        got += [(f.board_id, f.sequence, f.counts.tobytes()) for f in parser.feed(chunk)]
        assert parser.buffered < parser.max_frame_size
    # Intact frames come out in order (as a subsequence: garbage could in principle carry a
    # valid frame, but no bit-flipped frame may ever pass the CRC).
    it = iter(got)
    assert all(any(g == want for g in it) for want in intact)
    for bad in corrupted:
        if bad not in intact:
            assert bad not in got


def test_forged_count_is_refused_before_buffering() -> None:
    head = struct.pack("<2sBBBBHHI", SYNC, 1, 1, 0, 0, 0, 60_000, 0)
    from skin_driver.protocol import _crc16

    head += struct.pack("<H", _crc16(head))
    parser = FrameParser()
    assert parser.feed(head + bytes(1000)) == []
    assert parser.stats.bad_headers == 1
    assert parser.buffered <= 1


def test_count_above_parser_limit_is_refused() -> None:
    parser = FrameParser(max_taxels=8)
    good = encode_frame(0, 0, np.arange(8))
    big = encode_frame(0, 1, np.arange(9))
    out = parser.feed(big + good)
    assert [f.sequence for f in out] == [0]
    assert parser.stats.bad_headers == 1


def test_corrupted_count_costs_only_that_frame() -> None:
    frames_ = [encode_frame(1, s, np.full(10, s)) for s in range(3)]
    bad = bytearray(frames_[1])
    bad[8] = 0xFF  # count 10 → 255: the header CRC catches it, nothing is waited for
    parser = FrameParser()
    out = parser.feed(frames_[0] + bad + frames_[2])
    assert [f.sequence for f in out] == [0, 2]
    assert parser.stats.header_crc_errors == 1
    assert parser.stats.boards[1].dropped == 1


def test_sequence_gaps_wraps_and_restarts() -> None:
    parser = FrameParser()
    seqs = [65533, 65534, 65535, 0, 1, 4, 5, 0, 1]
    for s in seqs:
        parser.feed(encode_frame(3, s, np.zeros(2)))
    track = parser.stats.boards[3]
    assert track.frames == len(seqs)
    assert track.dropped == 2  # 2 and 3 missing; the wrap 65535 → 0 is no gap
    assert track.restarts == 1  # 5 → 0: the board restarted
    assert parser.stats.dropped == 2


def test_byte_by_byte_feed_with_split_sync() -> None:
    data = b"\xa5" + encode_frame(0, 9, np.arange(5)) + b"\x00\xa5"
    parser = FrameParser()
    out = []
    for b in data:
        out += parser.feed(bytes([b]))
    assert [f.sequence for f in out] == [9]
    assert parser.buffered == 1  # the trailing 0xA5 may start a sync
    assert parser.stats.discarded_bytes == 2
    assert HEADER_SIZE == 16


def _forged_header(count: int, board: int = 4, seq: int = 999) -> bytes:
    """A header with a valid CRC announcing ``count`` taxels, followed by nothing of its own."""
    head = struct.pack("<2sBBBBHHI", SYNC, 1, 1, board, 0, seq, count, 0)
    return head + struct.pack("<H", _crc16_ccitt_false(head))


@pytest.mark.parametrize("forged_counts", [[10_000], [16_384, 5_000], [37]])
def test_forged_length_costs_no_intact_frame_and_no_stall(forged_counts: list[int]) -> None:
    # A 36-taxel board at 500 Hz: one 92-byte frame per 2 ms read. Forged headers with valid
    # CRCs announce a long frame after frame 3 (37 = just one taxel more than the real size).
    real = [encode_frame(4, s, np.full(36, 1000 + s), board_time_us=2000 * s) for s in range(40)]
    chunks = [*real[:4], b"".join(_forged_header(c) for c in forged_counts), *real[4:]]
    parser = FrameParser()
    delivered: list[tuple[int, int]] = []  # (chunk index, sequence)
    for i, chunk in enumerate(chunks):
        delivered += [(i, f.sequence) for f in parser.feed(chunk)]
    assert [seq for _, seq in delivered] == list(range(40))  # every intact frame, in order
    for i, seq in delivered:  # each returned by the very read that completed it
        assert chunks[i] == real[seq]
    assert parser.stats.errors == len(forged_counts)  # a false length or a frame CRC error
    assert parser.stats.boards[4].dropped == 0
    assert parser.buffered == 0


def test_forged_length_overwriting_a_frame_costs_only_that_frame() -> None:
    real = [encode_frame(2, s, np.full(8, s)) for s in range(6)]
    damaged = _forged_header(12_000, board=2) + real[2][16:]  # header of frame 2 replaced
    parser = FrameParser()
    out = []
    for chunk in [real[0], real[1], damaged, real[3], real[4], real[5]]:
        out += [f.sequence for f in parser.feed(chunk)]
    assert out == [0, 1, 3, 4, 5]
    assert parser.stats.boards[2].dropped == 1


def test_a_real_long_frame_arriving_in_pieces_is_not_abandoned() -> None:
    counts = np.arange(5000) % 65536
    counts[100:102] = [0x5AA5, 0x0001]  # a sync pair inside the payload
    data = encode_frame(1, 7, counts)
    parser = FrameParser()
    out = [f for k in range(0, len(data), 97) for f in parser.feed(data[k : k + 97])]
    assert len(out) == 1 and out[0].sequence == 7
    assert parser.stats.false_lengths == 0 and parser.stats.errors == 0


# --- work linear in the bytes read -----------------------------------------------------------

WORK_PER_BYTE = 8
"""Bound on ``stats.checked_bytes`` / ``stats.bytes_in``: the running CRC passes each byte once,
and each sync (≥ 2 bytes apart) costs one 14-byte header CRC."""


def forged_burst(size: int, count: int = MAX_TAXELS) -> bytes:
    """``size`` bytes of back-to-back headers with valid header CRCs, each announcing ``count``
    taxels: every header starts inside the span of the ones before it, and no announced frame
    is intact (its CRC field holds later headers)."""
    return b"".join(_forged_header(count, seq=k) for k in range(size // HEADER_SIZE))


def _feed_checking_work(parser: FrameParser, data: bytes, chunk: int) -> list:
    """Feed ``data`` in chunks of ``chunk`` bytes, checking the work bound after every one."""
    out = []
    for k in range(0, len(data), chunk):
        out += parser.feed(data[k : k + chunk])
        s = parser.stats
        assert s.checked_bytes <= WORK_PER_BYTE * s.bytes_in, (k, s.checked_bytes, s.bytes_in)
        assert s.crc_combines <= s.bytes_in // 2
    return out


@pytest.mark.parametrize("chunk", [4096, 92, 1 << 20])
def test_forged_headers_cost_work_linear_in_the_bytes(chunk: int) -> None:
    burst = forged_burst(1 << 20)
    real = [encode_frame(4, s, np.full(36, 1000 + s)) for s in range(3)]
    parser = FrameParser()
    assert _feed_checking_work(parser, burst, chunk) == []
    s = parser.stats
    # Every header whose announced frame is in was checked, once, and refused.
    spanned = (len(burst) - frame_size(MAX_TAXELS)) // HEADER_SIZE + 1
    assert s.frame_crc_errors == spanned and s.crc_combines == spanned
    assert parser.buffered < parser.max_frame_size
    # The next good frames are used: the headers still waiting are false lengths, and every
    # sync of the burst (a header's, or one its fields happen to spell) was refused once.
    out = _feed_checking_work(parser, b"".join(real), chunk)
    assert [f.sequence for f in out] == [0, 1, 2]
    assert s.false_lengths > 0 and s.errors == burst.count(SYNC)
    assert s.discarded_bytes == len(burst) and parser.buffered == 0


def test_a_clean_stream_checks_each_byte_once() -> None:
    data = b"".join(encode_frame(1, s, np.arange(2000) + s) for s in range(50))
    parser = FrameParser()
    out = _feed_checking_work(parser, data, 4096)
    assert [f.sequence for f in out] == list(range(50))
    # Each frame: its 14 header bytes by the CRC-16, then every byte up to its CRC field once.
    assert parser.stats.checked_bytes == 50 * (14 + frame_size(2000) - 4)


@SETTINGS
@given(data=st.binary(max_size=3000), salt=st.integers(0, 400),
       cuts=st.lists(st.integers(0, 5000), max_size=20))
def test_work_stays_linear_on_any_stream(data: bytes, salt: int, cuts: list[int]) -> None:
    # Random bytes, syncs and valid headers of small frames, all overlapping.
    rng = np.random.default_rng(len(data) + salt)
    stream = bytearray(data)
    for _ in range(salt):
        at = int(rng.integers(0, len(stream) + 1))
        piece = (SYNC if rng.random() < 0.5
                 else _forged_header(int(rng.integers(1, MAX_T + 1)), seq=int(rng.integers(99))))
        stream[at:at] = piece
    parser = FrameParser(MAX_T)
    for chunk in _chunks(bytes(stream), cuts):
        parser.feed(chunk)
        s = parser.stats
        assert s.checked_bytes <= WORK_PER_BYTE * s.bytes_in
        assert parser.buffered < parser.max_frame_size + len(chunk)


def test_crc_of_a_span_from_running_crcs_matches_zlib() -> None:
    from skin_driver.protocol import crc32_of_span

    data = np.random.default_rng(0).integers(0, 256, 5000, dtype=np.uint8).tobytes()
    for s, e in [(0, 5000), (10, 4000), (123, 124), (7, 7), (0, 0), (4999, 5000)]:
        assert crc32_of_span(zlib.crc32(data[:s]), zlib.crc32(data[:e]), e - s) == zlib.crc32(
            data[s:e])
