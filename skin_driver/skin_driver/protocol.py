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

The parser's work is linear in the bytes it reads, whatever the stream: each sync is examined
once, and each candidate frame's CRC-32 comes in constant time from the running CRC-32 of the
stream (:func:`crc32_of_span`), so back-to-back forged headers, each starting inside the
previous one's span, cost no more CRC work per byte than a clean stream
(``ParserStats.checked_bytes`` ≤ 8 × ``bytes_in``; ``bench/bench_parser.py`` measures it).
"""

from __future__ import annotations

import binascii
import heapq
import struct
import zlib
from collections import deque
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
        checked_bytes: bytes run through a CRC (header and frame checks): the parser's work
            measure, at most ``bytes_in`` + 14 per sync ≤ 8 × ``bytes_in`` [bytes].
        crc_combines: frame CRCs derived from the running CRC (one per complete frame with
            a valid header, ≤ ``bytes_in`` / 2).
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
    checked_bytes: int = 0
    crc_combines: int = 0
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


# --- CRC-32 of a span from the running CRC-32 of the stream (zlib's crc32_combine) ----------

_POLY32 = 0xEDB88320
"""The CRC-32 (IEEE) polynomial, reflected (bit 31 is x⁰), as zlib."""


def _multmodp(a: int, b: int) -> int:
    """a·b modulo the CRC-32 polynomial, both reflected (zlib's ``multmodp``); ``a`` ≠ 0."""
    m = 1 << 31
    p = 0
    while True:
        if a & m:
            p ^= b
            if a & (m - 1) == 0:
                return p
        m >>= 1
        b = (b >> 1) ^ _POLY32 if b & 1 else b >> 1


_X2N = [1 << 30]
"""x^(2^k) modulo the polynomial, k = 0…31 (x¹ is bit 30 when reflected)."""
for _k in range(31):
    _X2N.append(_multmodp(_X2N[-1], _X2N[-1]))

_X8N: dict[int, int] = {}
"""Cache of :func:`_x8n` (one entry per span length seen: ≤ MAX_TAXELS entries)."""


def _x8n(n: int) -> int:
    """x^(8n) modulo the polynomial: what moves a CRC-32 past ``n`` bytes."""
    p = _X8N.get(n)
    if p is None:
        p, k, m = 1 << 31, 3, n
        while m:
            if m & 1:
                p = _multmodp(_X2N[k & 31], p)
            m >>= 1
            k += 1
        _X8N[n] = p
    return p


def crc32_of_span(crc_to_start: int, crc_to_end: int, span: int) -> int:
    """CRC-32 (as ``zlib.crc32``) of the bytes ``[s, e)`` of a stream, from the running
    CRC-32 of the stream up to ``s`` and up to ``e`` (from the same origin) and ``span`` =
    e − s [bytes], in constant time: crc(A‖B) = crc(A)·x^(8|B|) ⊕ crc(B) (zlib's
    ``crc32_combine``, solved for crc(B))."""
    if crc_to_start == 0:
        return crc_to_end
    return crc_to_end ^ _multmodp(_x8n(span), crc_to_start)


# --- the streaming parser ---------------------------------------------------------------------

_PENDING, _INTACT = 5, 6
"""Candidate states besides _WAIT and the rejections: header incomplete; an intact frame."""


class _Candidate:
    """A sync found in the stream and what is known of the frame it may start.

    Attributes:
        pos: stream offset of the sync [bytes].
        state: ``_PENDING`` (header incomplete), ``_WAIT`` (valid header, frame incomplete),
            ``_INTACT``, or a rejection (``_HEADER_CRC``, ``_BAD_HEADER``, ``_FRAME_CRC``,
            ``_FALSE_LENGTH``).
        crc_start: running CRC-32 of the stream up to ``pos`` (open candidates only).
        crc_end: stream offset of the frame CRC field (valid header only) [bytes].
        dead: consumed (inside an emitted frame, or rejected): its heap entries are stale.
    """

    __slots__ = ("board", "btime", "count", "crc_end", "crc_start", "dead", "flags", "pos",
                 "seq", "state")

    def __init__(self, pos: int) -> None:
        self.pos = pos
        self.state = _PENDING
        self.crc_start = 0
        self.crc_end = 0
        self.board = self.flags = self.seq = self.count = self.btime = 0
        self.dead = False

    @property
    def open(self) -> bool:
        """Its frame CRC still needs the running CRC (header incomplete or frame incomplete)."""
        return self.state in (_PENDING, _WAIT)


class FrameParser:
    """Streaming, incremental protocol-v1 parser with work linear in the bytes fed.

    Feed it bytes in chunks of any size; it returns every intact frame and skips everything
    else. Every sync (0xA5 0x5A) in the stream is a candidate frame start, examined once:

    * its header CRC is checked once, when its 16 header bytes are in (14 bytes of CRC-16);
    * a valid header announces where its frame ends; the frame CRC is checked once, when
      that end is in, in constant time from the running CRC-32 of the stream
      (:func:`crc32_of_span`). The running CRC passes over each byte at most once, so the
      CRC work is at most ``bytes_in`` + 14 per sync ≤ 8 × ``bytes_in``
      (``stats.checked_bytes``), however many forged headers overlap.

    Candidates are resolved in stream order: an intact frame is returned by the chunk that
    completes it; syncs inside it are skipped. Resynchronisation: a rejected candidate costs
    one byte and the next sync is the next candidate, so a real frame hidden inside a false
    one is still found. Look-ahead: while the first candidate waits for the rest of a frame,
    an intact frame that starts after it proves its announced length false (a forged header
    with a valid CRC): it is counted as a false length and dropped at once, so a bad length
    delays the next intact frame by nothing. Memory: the buffer never holds more than one
    maximal frame plus the chunk just fed; the bookkeeping, one small record per sync in it.

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
        self.reset()

    @property
    def buffered(self) -> int:
        """Bytes held waiting for the rest of a frame [bytes]."""
        return len(self._buf)

    def reset(self) -> None:
        """Forget buffered bytes (after a reconnect: the stream is discontinuous)."""
        self._buf = bytearray()
        self._base = 0  # stream offset of _buf[0]; all offsets below are stream offsets
        self._done = 0  # every byte before it is consumed (returned in a frame or discarded)
        self._scan = 0  # the next sync search starts here
        self._cands: deque[_Candidate] = deque()  # unconsumed syncs, in stream order
        self._ends: list[tuple[int, int, _Candidate]] = []  # heap: (crc_end, pos, candidate)
        self._pending: list[_Candidate] = []  # candidates whose header is incomplete
        self._intact: list[tuple[int, _Candidate]] = []  # heap: (pos, candidate)
        self._open = 0  # live candidates that are open (their CRC needs the running CRC)
        self._crc_pos = 0  # the running CRC-32 covers the stream up to here …
        self._crc = 0  # … from an origin chosen when no candidate was open
        self._in_sync = True

    def feed(self, data: bytes | bytearray | memoryview) -> list[Frame]:
        """Consume ``data``; return the frames it completed, in stream order."""
        self.stats.bytes_in += len(data)
        self._buf += data
        end = self._base + len(self._buf)
        if self._pending:
            self._complete_headers(end)
        self._scan_syncs(end)
        self._close_ends(end - TRAILER_SIZE)
        frames = self._resolve()
        self._trim(end)
        return frames

    def _complete_headers(self, end: int) -> None:
        """Read the headers that were incomplete and are now in (``end``: stream end)."""
        still = []
        for cand in self._pending:
            if cand.dead:
                continue
            if end - cand.pos < HEADER_SIZE:
                still.append(cand)
                continue
            cand.state = self._header_at(cand.pos)
            if cand.state == _WAIT:
                self._take_header(cand)
                heapq.heappush(self._ends, (cand.crc_end, cand.pos, cand))
            else:
                self._open -= 1
        self._pending = still

    def _scan_syncs(self, end: int) -> None:
        """Make a candidate of every new sync up to ``end`` − 4 (one beyond it has no
        complete header yet: the next feed takes it), closing the frames that end before
        each (the running CRC moves forward only)."""
        buf, base, ends = self._buf, self._base, self._ends
        while True:
            i = buf.find(SYNC, max(self._scan, self._done) - base)
            if i < 0:
                self._scan = max(self._scan, end - 1)
                return
            pos = base + i
            if pos > end - TRAILER_SIZE:
                self._scan = pos
                return
            self._scan = pos + 1
            if ends and ends[0][0] <= pos:
                self._close_ends(pos)
            self._add_candidate(pos, end)

    def _add_candidate(self, pos: int, end: int) -> None:
        if end - pos < HEADER_SIZE:
            cand = _Candidate(pos)
            self._pending.append(cand)
        else:
            verdict = self._header_at(pos)
            if verdict != _WAIT and not self._cands:
                # Nothing before it can still become a frame that covers it: refused now,
                # its bytes are discarded by _trim (the common case in garbage: no record).
                self._count_rejection(verdict)
                return
            cand = _Candidate(pos)
            cand.state = verdict
            if verdict == _WAIT:
                self._take_header(cand)
                heapq.heappush(self._ends, (cand.crc_end, pos, cand))
        self._cands.append(cand)
        if cand.open:
            cand.crc_start = self._crc_to(pos)
            self._open += 1

    def _header_at(self, pos: int) -> int:
        """Check the (complete) header at stream offset ``pos``: ``_WAIT`` (valid: its frame
        is awaited) or why it is refused (``_HEADER_CRC``, ``_BAD_HEADER``)."""
        at = pos - self._base
        buf = self._buf
        self.stats.checked_bytes += _HEADER.size
        if _crc16(buf[at : at + _HEADER.size]) != buf[at + 14] | buf[at + 15] << 8:
            return _HEADER_CRC
        count = buf[at + 8] | buf[at + 9] << 8
        if (buf[at + 2] != PROTOCOL_VERSION or buf[at + 3] != ENCODING_U16
                or not 1 <= count <= self.max_taxels):
            return _BAD_HEADER
        return _WAIT

    def _take_header(self, cand: _Candidate) -> None:
        """Copy the fields of ``cand``'s valid header."""
        (_, _, _, cand.board, cand.flags, cand.seq, cand.count, cand.btime) = (
            _HEADER.unpack_from(self._buf, cand.pos - self._base))
        cand.crc_end = cand.pos + HEADER_SIZE + COUNT_BYTES * cand.count

    def _crc_to(self, pos: int) -> int:
        """The running CRC-32 up to stream offset ``pos`` (≥ where it is). With no open
        candidate nothing depends on its origin: it restarts at ``pos`` (0) for free."""
        if self._open == 0:
            self._crc_pos, self._crc = pos, 0
            return 0
        lo, hi = self._crc_pos - self._base, pos - self._base
        self._crc = zlib.crc32(memoryview(self._buf)[lo:hi], self._crc)
        self.stats.checked_bytes += hi - lo
        self._crc_pos = pos
        return self._crc

    def _close_ends(self, limit: int) -> None:
        """Check the frame CRC of every open candidate whose frame is complete and whose CRC
        field starts at or before stream offset ``limit``, in stream order of those fields."""
        ends = self._ends
        while ends and ends[0][0] <= limit:
            _, _, cand = heapq.heappop(ends)
            if cand.dead:
                continue
            crc_to_end = self._crc_to(cand.crc_end)
            self._open -= 1
            self.stats.crc_combines += 1
            crc = crc32_of_span(cand.crc_start, crc_to_end, cand.crc_end - cand.pos)
            (expected,) = struct.unpack_from("<I", self._buf, cand.crc_end - self._base)
            if crc == expected:
                cand.state = _INTACT
                heapq.heappush(self._intact, (cand.pos, cand))
            else:
                cand.state = _FRAME_CRC

    def _resolve(self) -> list[Frame]:
        """Consume candidates from the front: return intact frames, count rejections, and
        drop a waiting candidate as a false length when an intact frame follows it."""
        frames: list[Frame] = []
        cands = self._cands
        while cands:
            cand = cands[0]
            if cand.state == _INTACT:
                frames.append(self._emit(cand))
                continue
            if cand.open:
                if not self._intact_follows():
                    break
                self._kill(cand)
                cand.state = _FALSE_LENGTH
            self._count_rejection(cand.state)
            cands.popleft()
        return frames

    def _intact_follows(self) -> bool:
        """Is there a live intact candidate (all follow the first live candidate)? Pops the
        dead ones off the heap's top: all lie before every live one, so none is left."""
        intact = self._intact
        while intact and intact[0][1].dead:
            heapq.heappop(intact)
        return bool(intact)

    def _kill(self, cand: _Candidate) -> None:
        if cand.open:
            self._open -= 1
        cand.dead = True

    def _emit(self, cand: _Candidate) -> Frame:
        """The intact frame of the first candidate; consumes it and the syncs inside it."""
        self._skip(self._done, cand.pos)
        counts = np.frombuffer(self._buf, dtype="<u2", count=cand.count,
                               offset=cand.pos - self._base + HEADER_SIZE).copy()
        frame = Frame(cand.board, cand.seq, cand.btime, cand.flags, counts)
        frame_end = cand.crc_end + TRAILER_SIZE
        cands = self._cands
        while cands and cands[0].pos < frame_end:
            self._kill(cands.popleft())
        self._done = frame_end
        self._in_sync = True
        self._intact_follows()  # drops this candidate (and any inside it) from the heap
        self._count_sequence(frame.board_id, frame.sequence)
        return frame

    def _trim(self, end: int) -> None:
        """Discard what is consumed: keep from the first candidate, or from a sync (or a
        trailing 0xA5) not yet taken as a candidate."""
        if self._cands:
            keep = self._cands[0].pos
        else:
            self._scan = max(self._scan, self._done)
            scan = self._scan
            keep = scan if scan < end and self._buf[scan - self._base] == SYNC[0] else end
        keep = max(keep, self._done)
        self._skip(self._done, keep)
        self._done = keep
        del self._buf[: keep - self._base]
        self._base = keep

    def _count_rejection(self, verdict: int) -> None:
        if verdict == _HEADER_CRC:
            self.stats.header_crc_errors += 1
        elif verdict == _BAD_HEADER:
            self.stats.bad_headers += 1
        elif verdict == _FRAME_CRC:
            self.stats.frame_crc_errors += 1
        elif verdict == _FALSE_LENGTH:
            self.stats.false_lengths += 1

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
