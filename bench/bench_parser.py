"""Benchmark: skin_driver's frame parser, before and after its look-ahead was made linear.

Parses, in one process, with the current :class:`skin_driver.protocol.FrameParser` ("after")
and with the parser as it was before (``QuadraticParser`` below: the same code, kept here as
the baseline, "before"):

* ``clean``: a clean stream of 2,000-taxel frames (the skin at 500 Hz), read in chunks;
* ``forged``: a burst of back-to-back forged headers (valid header CRCs, 16,384 taxels
  announced, one every 16 bytes: each starts inside the span of the ones before it, none is
  intact), then clean frames (which complete the announced spans);
* ``garbage``: random bytes salted with sync pairs.

It reports throughput [MB/s] (bytes fed / CPU time of ``feed``, median of ``--repeat``) and
the deterministic work measure: bytes run through a CRC per byte fed (the current parser keeps
it ≤ 8; see ``ParserStats.checked_bytes``). The baseline's forged burst is kept short by
default (``--before-burst-kib``): its work grows with the square of the burst.

Run: ``.venv/bin/python bench/bench_parser.py [--burst-kib 1024] [--before-burst-kib 16]
[--clean-mib 4] [--chunk 4096] [--repeat 3]``.
"""

from __future__ import annotations

import argparse
import statistics
import struct
import time
import zlib
from collections.abc import Callable
from typing import Any

import numpy as np

from phri_common.procstat import load_line
from skin_driver.protocol import (
    _BAD_HEADER,
    _FALSE_LENGTH,
    _FRAME_CRC,
    _HEADER,
    _HEADER_CRC,
    _WAIT,
    ENCODING_U16,
    HEADER_SIZE,
    MAX_TAXELS,
    PROTOCOL_VERSION,
    SYNC,
    TRAILER_SIZE,
    BoardSequence,
    Frame,
    FrameParser,
    ParserStats,
    _crc16,
    encode_frame,
    frame_size,
)


class QuadraticParser:
    """The parser before the linear look-ahead (skin_driver/protocol.py at ba33500), with
    ``stats.checked_bytes`` counted the same way: every look-ahead restarts its scan at the
    first candidate after a new head, and checks each complete candidate's frame CRC over its
    whole span again."""

    def __init__(self, max_taxels: int = MAX_TAXELS) -> None:
        self.max_taxels = max_taxels
        self.stats = ParserStats()
        self._buf = bytearray()
        self._in_sync = True
        self._probe = 1

    def feed(self, data: bytes | bytearray | memoryview) -> list[Frame]:
        self.stats.bytes_in += len(data)
        buf = self._buf
        buf += data
        frames: list[Frame] = []
        pos = 0
        n = len(buf)
        while True:
            start = buf.find(SYNC, pos)
            if start < 0:
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
            self.stats.frames += 1
            self.stats.boards.setdefault(verdict.board_id, BoardSequence()).observe(
                verdict.sequence)
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
        if n - pos < HEADER_SIZE:
            return _WAIT
        (_, version, encoding, board, flags, seq, count, btime) = _HEADER.unpack_from(buf, pos)
        (hcrc,) = struct.unpack_from("<H", buf, pos + _HEADER.size)
        self.stats.checked_bytes += _HEADER.size
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
        self.stats.checked_bytes += end - pos
        if zlib.crc32(memoryview(buf)[pos:end]) != fcrc:
            return _FRAME_CRC
        counts = np.frombuffer(buf, dtype="<u2", count=count, offset=pos + HEADER_SIZE).copy()
        return Frame(board, seq, btime, flags, counts)

    def _intact_frame_inside(self, buf: bytearray, pos: int, n: int) -> bool:
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
        if end > begin:
            if self._in_sync:
                self.stats.resyncs += 1
                self._in_sync = False
            self.stats.discarded_bytes += end - begin


def forged_header(count: int, seq: int) -> bytes:
    """A header with a valid CRC announcing ``count`` taxels, and nothing of its frame."""
    head = _HEADER.pack(SYNC, PROTOCOL_VERSION, ENCODING_U16, 4, 0, seq % 65536, count, 0)
    return head + struct.pack("<H", _crc16(head))


def clean_stream(size: int, taxels: int = 2000) -> bytes:
    """About ``size`` bytes of intact frames of ``taxels`` taxels [bytes]."""
    rng = np.random.default_rng(0)
    n = max(1, size // frame_size(taxels))
    return b"".join(encode_frame(1, s, rng.integers(0, 4000, taxels)) for s in range(n))


def forged_stream(burst: int) -> bytes:
    """``burst`` bytes of forged headers, then the clean frames that complete their spans."""
    headers = b"".join(forged_header(MAX_TAXELS, k) for k in range(burst // HEADER_SIZE))
    return headers + clean_stream(frame_size(MAX_TAXELS) + 8192)


def garbage_stream(size: int) -> bytes:
    """``size`` random bytes with a sync pair every 64 bytes on average."""
    rng = np.random.default_rng(1)
    data = bytearray(rng.integers(0, 256, size, dtype=np.uint8).tobytes())
    for at in rng.integers(0, size - 1, size // 64):
        data[at : at + 2] = SYNC
    return bytes(data)


def measure(make: Callable[[], Any], data: bytes, chunk: int, repeat: int) -> tuple[float, Any]:
    """Median throughput [MB/s] of ``make()``'s parser over ``data`` in ``chunk``-byte reads,
    and the stats of the last run."""
    rates, stats = [], None
    for _ in range(repeat):
        parser = make()
        t0 = time.process_time()
        for k in range(0, len(data), chunk):
            parser.feed(data[k : k + chunk])
        rates.append(len(data) / max(time.process_time() - t0, 1e-9) / 1e6)
        stats = parser.stats
    return statistics.median(rates), stats


def main() -> int:
    p = argparse.ArgumentParser(description=(__doc__ or "").split("\n")[0])
    p.add_argument("--burst-kib", type=int, default=1024, help="forged burst, after [KiB]")
    p.add_argument("--before-burst-kib", type=int, default=16,
                   help="forged burst of the baseline (work ∝ burst²) [KiB]")
    p.add_argument("--clean-mib", type=float, default=4.0, help="clean stream [MiB]")
    p.add_argument("--chunk", type=int, default=4096, help="bytes per read")
    p.add_argument("--repeat", type=int, default=3)
    args = p.parse_args()
    print(load_line())
    print(f"reads of {args.chunk} bytes; throughput = bytes fed / CPU time, median of "
          f"{args.repeat}; work = CRC'd bytes per byte fed")
    cases = [
        ("clean", clean_stream(int(args.clean_mib * 2**20)), None),
        ("garbage", garbage_stream(int(args.clean_mib * 2**20)), None),
        ("forged", forged_stream(args.burst_kib * 1024),
         forged_stream(args.before_burst_kib * 1024)),
    ]
    for name, data, before_data in cases:
        for label, make, stream in (("before", QuadraticParser, before_data or data),
                                    ("after", FrameParser, data)):
            rate, stats = measure(make, stream, args.chunk, args.repeat)
            print(f"{name:8s} {label:6s} {len(stream) / 2**20:7.3f} MiB  {rate:9.3f} MB/s  "
                  f"work {stats.checked_bytes / stats.bytes_in:8.2f}/byte  "
                  f"frames {stats.frames}, errors {stats.errors}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
