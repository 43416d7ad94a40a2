"""The skin board serial protocol, version 1: frame encoder and streaming parser (pure).

The wire format is specified in ``docs/skin_protocol.md``; this module is its reference
implementation. One frame (all integers little-endian)::

    offset  size  field
    0       2     sync            0xA5 0x5A
    2       1     version         1
    3       1     encoding        1 = unsigned 16-bit raw counts per taxel
    4       1     board_id        0…255
    5       1     flags           bit 0: board-side overrun (a sample was skipped); others 0
    6       2     sequence        +1 per frame, wraps 65535 → 0
    8       2     taxel_count     N, 1 … MAX_TAXELS
    10      4     board_time_us   board clock at sampling [µs], wraps
    14      2     header_crc      CRC-16/CCITT-FALSE of bytes 0…13
    16      2N    payload         N raw counts (uint16)
    16+2N   4     frame_crc       CRC-32 (IEEE, as zlib.crc32) of bytes 0 … 15+2N

The header carries its own CRC so that a corrupted ``taxel_count`` is rejected before the parser
waits for a payload that never comes; every length is bounded by :data:`MAX_TAXELS` (and by the
parser's own, possibly smaller, ``max_taxels``), so a forged count cannot make the parser buffer
more than one maximal frame plus the chunk being fed. A forged header *with* a valid CRC and a
legal but wrong count is caught by looking ahead: while the parser waits for the rest of a
frame, an intact frame (both CRCs valid) that starts inside the awaited span proves the awaited
length false, and the parser moves on at once. So a bad length costs at most the frames it
overlaps and delays the next intact frame by nothing (it is returned by the chunk that completes
it), with no change to the wire format.
"""

from __future__ import annotations

import binascii
import struct
import zlib
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

PROTOCOL_VERSION = 1
SYNC = b"\xa5\x5a"
ENCODING_U16 = 1
FLAG_OVERRUN = 0x01
MAX_TAXELS = 16384
"""Protocol limit on taxels per frame (a 128 × 128 patch); payload ≤ 32 KiB."""

_HEADER = struct.Struct("<2sBBBBHHI")  # up to (excluding) the header CRC
HEADER_SIZE = _HEADER.size + 2
TRAILER_SIZE = 4
COUNT_BYTES = 2
SEQUENCE_MODULO = 1 << 16


# Verdicts of FrameParser._frame_at besides an intact Frame.
_WAIT, _HEADER_CRC, _BAD_HEADER, _FRAME_CRC, _FALSE_LENGTH = range(5)


def frame_size(taxel_count: int) -> int:
    """Bytes on the wire for a frame of ``taxel_count`` taxels."""
    return HEADER_SIZE + COUNT_BYTES * taxel_count + TRAILER_SIZE


def _crc16(data: bytes | bytearray | memoryview) -> int:
    # binascii.crc_hqx is CRC-16/CCITT (poly 0x1021); init 0xFFFF makes it CCITT-FALSE.
    return binascii.crc_hqx(data, 0xFFFF)


def encode_frame(
    board_id: int,
    sequence: int,
    counts: NDArray[np.integer],
    board_time_us: int = 0,
    flags: int = 0,
) -> bytes:
    """Encode one protocol-v1 frame.

    Args:
        board_id: 0…255.
        sequence: frame counter; taken modulo 65536.
        counts: (N,) raw counts, 0…65535, 1 ≤ N ≤ :data:`MAX_TAXELS`.
        board_time_us: board clock [µs]; taken modulo 2³².
        flags: flag bits (:data:`FLAG_OVERRUN`).

    Raises:
        ValueError: an argument is out of range.
    """
    counts = np.asarray(counts)
    if counts.ndim != 1 or not 1 <= counts.shape[0] <= MAX_TAXELS:
        raise ValueError(f"counts must be 1-D with 1…{MAX_TAXELS} taxels, got {counts.shape}")
    if not 0 <= board_id <= 255:
        raise ValueError(f"board_id must be 0…255, got {board_id}")
    if not 0 <= flags <= 255:
        raise ValueError(f"flags must be 0…255, got {flags}")
    if counts.dtype != np.dtype("<u2"):
        if counts.size and (int(counts.min()) < 0 or int(counts.max()) > 0xFFFF):
            raise ValueError("counts must lie in 0…65535")
        counts = counts.astype("<u2")
    head = _HEADER.pack(
        SYNC,
        PROTOCOL_VERSION,
        ENCODING_U16,
        board_id,
        flags,
        sequence % SEQUENCE_MODULO,
        counts.shape[0],
        board_time_us % (1 << 32),
    )
    head += struct.pack("<H", _crc16(head))
    body = head + counts.tobytes()
    return body + struct.pack("<I", zlib.crc32(body))


@dataclass(frozen=True)
class Frame:
    """One decoded frame.

    Attributes:
        board_id: sending board.
        sequence: frame counter (mod 65536).
        board_time_us: board clock at sampling [µs] (mod 2³²).
        flags: flag bits.
        counts: (N,) raw counts, ``uint16`` (an owned array).
    """

    board_id: int
    sequence: int
    board_time_us: int
    flags: int
    counts: NDArray[np.uint16]


@dataclass
class BoardSequence:
    """Sequence bookkeeping for one board id.

    A sequence gap of ``0 < g < 32768`` frames counts as ``g`` dropped frames; a larger jump
    (backwards, e.g. a board reset) counts as a restart.
    """

    last: int | None = None
    frames: int = 0
    dropped: int = 0
    restarts: int = 0

    def observe(self, seq: int) -> None:
        """Account for one received frame with sequence number ``seq``."""
        if self.last is not None:
            gap = (seq - self.last - 1) % SEQUENCE_MODULO
            if 0 < gap < SEQUENCE_MODULO // 2:
                self.dropped += gap
            elif gap != 0:
                self.restarts += 1
        self.last = seq
        self.frames += 1


@dataclass
class ParserStats:
    """Counters since the parser was created (monotonic; never reset by the parser).

    Attributes:
        bytes_in: bytes fed.
        frames: intact frames returned.
        header_crc_errors: sync found but the header CRC failed.
        bad_headers: header CRC passed but version, encoding or count are invalid.
        false_lengths: header CRC passed, but an intact frame started inside the length it
            announced (a forged or corrupted length): abandoned without waiting.
        frame_crc_errors: header valid, frame CRC failed.
        resyncs: times the parser dropped bytes to look for the next sync.
        discarded_bytes: bytes skipped while resynchronising.
        boards: per board id: frames, dropped frames (sequence gaps), sequence restarts.
    """

    bytes_in: int = 0
    frames: int = 0
    header_crc_errors: int = 0
    bad_headers: int = 0
    false_lengths: int = 0
    frame_crc_errors: int = 0
    resyncs: int = 0
    discarded_bytes: int = 0
    boards: dict[int, BoardSequence] = field(default_factory=dict)

    @property
    def crc_errors(self) -> int:
        return self.header_crc_errors + self.frame_crc_errors

    @property
    def errors(self) -> int:
        """Every rejected header or frame (CRC, bad header, false length)."""
        return self.crc_errors + self.bad_headers + self.false_lengths

    @property
    def dropped(self) -> int:
        return sum(b.dropped for b in self.boards.values())


class FrameParser:
    """Streaming, incremental protocol-v1 parser.

    Feed it bytes in chunks of any size; it returns every intact frame and skips everything
    else. Resynchronisation: after a bad header or CRC it advances one byte past the failed sync
    and searches again, so a real frame hidden inside a false one is still found. While it
    waits for the rest of a frame it looks ahead: an intact frame starting inside the awaited
    span proves the announced length false (a forged header with a valid CRC), and the parser
    moves on at once. Memory: the internal buffer never holds more than one maximal frame plus
    the chunk just fed.

    ``stats.boards`` counts sequence gaps of every intact frame in the stream (see
    :class:`BoardSequence`); a consumer that drops some frames (unknown board, wrong size)
    keeps its own :class:`BoardSequence` for the frames it accepts.
    """

    def __init__(self, max_taxels: int = MAX_TAXELS) -> None:
        if not 1 <= max_taxels <= MAX_TAXELS:
            raise ValueError(f"max_taxels must be 1…{MAX_TAXELS}, got {max_taxels}")
        self.max_taxels = max_taxels
        self.max_frame_size = frame_size(max_taxels)
        self.stats = ParserStats()
        self._buf = bytearray()
        self._in_sync = True
        self._probe = 1  # look-ahead resumes here, relative to the awaited frame's start

    @property
    def buffered(self) -> int:
        """Bytes held waiting for the rest of a frame [bytes]."""
        return len(self._buf)

    def reset(self) -> None:
        """Forget buffered bytes (after a reconnect: the stream is discontinuous)."""
        self._buf.clear()
        self._in_sync = True
        self._probe = 1

    def feed(self, data: bytes | bytearray | memoryview) -> list[Frame]:
        """Consume ``data``; return the frames it completed, in stream order."""
        self.stats.bytes_in += len(data)
        buf = self._buf
        buf += data
        frames: list[Frame] = []
        pos = 0
        n = len(buf)
        while True:
            start = buf.find(SYNC, pos)
            if start < 0:
                # Keep a trailing first sync byte: the second may arrive in the next chunk.
                keep_from = n - 1 if n > pos and buf[n - 1] == SYNC[0] else n
                self._skip(pos, keep_from)
                pos = keep_from
                break
            if start > pos:
                self._skip(pos, start)
                self._probe = 1
            pos = start
            verdict = self._frame_at(buf, pos, n)
            if verdict == _WAIT:
                if n - pos >= HEADER_SIZE and self._intact_frame_inside(buf, pos, n):
                    self.stats.false_lengths += 1
                    verdict = _FALSE_LENGTH
                else:
                    break
            if isinstance(verdict, int):
                self._count_rejection(verdict)
                self._skip(pos, pos + 1)
                self._probe = 1
                pos += 1
                continue
            frames.append(verdict)
            self._in_sync = True
            self._count_sequence(verdict.board_id, verdict.sequence)
            self._probe = 1
            pos += frame_size(verdict.counts.shape[0])
        del buf[:pos]
        return frames

    def _count_rejection(self, verdict: int) -> None:
        if verdict == _HEADER_CRC:
            self.stats.header_crc_errors += 1
        elif verdict == _BAD_HEADER:
            self.stats.bad_headers += 1
        elif verdict == _FRAME_CRC:
            self.stats.frame_crc_errors += 1

    def _frame_at(self, buf: bytearray, pos: int, n: int) -> Frame | int:
        """The intact frame starting at ``buf[pos]`` (a sync), or why not (``_WAIT`` = need
        more bytes; the other codes: rejected). Updates no counter."""
        if n - pos < HEADER_SIZE:
            return _WAIT
        (_, version, encoding, board, flags, seq, count, btime) = _HEADER.unpack_from(buf, pos)
        (hcrc,) = struct.unpack_from("<H", buf, pos + _HEADER.size)
        if _crc16(memoryview(buf)[pos : pos + _HEADER.size]) != hcrc:
            return _HEADER_CRC
        if version != PROTOCOL_VERSION or encoding != ENCODING_U16:
            return _BAD_HEADER
        if not 1 <= count <= self.max_taxels:
            return _BAD_HEADER
        size = frame_size(count)
        if n - pos < size:
            return _WAIT
        end = pos + size - TRAILER_SIZE
        (fcrc,) = struct.unpack_from("<I", buf, end)
        if zlib.crc32(memoryview(buf)[pos:end]) != fcrc:
            return _FRAME_CRC
        counts = np.frombuffer(buf, dtype="<u2", count=count, offset=pos + HEADER_SIZE).copy()
        return Frame(board, seq, btime, flags, counts)

    def _intact_frame_inside(self, buf: bytearray, pos: int, n: int) -> bool:
        """Does an intact frame start inside the incomplete frame announced at ``buf[pos]``?

        Scans the syncs after ``pos`` (from where the previous call left off: candidates
        already ruled out are not checked again). A candidate still incomplete is checked
        again on the next call; later candidates are checked meanwhile, so a second forged
        header cannot hold up the first intact frame either.
        """
        probe = pos + max(self._probe, 1)
        undecided = -1
        while True:
            cand = buf.find(SYNC, probe, n)
            if cand < 0 or n - cand < HEADER_SIZE:
                break
            verdict = self._frame_at(buf, cand, n)
            if isinstance(verdict, Frame):
                return True
            if verdict == _WAIT and undecided < 0:
                undecided = cand
            probe = cand + 1
        resume = undecided if undecided >= 0 else (cand if cand >= 0 else n - 1)
        self._probe = max(resume - pos, 1)
        return False

    def _skip(self, begin: int, end: int) -> None:
        # One resync per run of skipped bytes between two good frames.
        if end > begin:
            if self._in_sync:
                self.stats.resyncs += 1
                self._in_sync = False
            self.stats.discarded_bytes += end - begin

    def _count_sequence(self, board: int, seq: int) -> None:
        self.stats.frames += 1
        track = self.stats.boards.get(board)
        if track is None:
            track = self.stats.boards[board] = BoardSequence()
        track.observe(seq)
