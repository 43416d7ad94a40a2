"""Simulated skin board: speaks protocol v1 into a pty or any pyserial URL (no rclpy).

Library use (the simulator feeds its own forces)::

    board = SimBoard(board_id=0, layout=layout)          # inverse of the layout's calibration
    data = board.frame(forces, t)                        # bytes of one frame (faults applied)

Program use (``sim_skin_board``): creates a pty (prints its path, optionally keeps a stable
symlink to it, as udev does for ``/dev/serial/by-id``), serves TCP (``--listen``: a board on
Ethernet, read at ``socket://HOST:PORT``) or opens ``--port URL``, and sends frames
at ``--rate`` Hz with a scripted press pattern or a replayed ``.npy`` recording, optionally with
injected faults: garbage bytes, bit flips, dropped frames and periodic disconnects.

Board model: ``count = offset + force / gain + noise`` rounded and clipped to 0…65535, with the
same per-taxel gain and offset the driver reads from the layout, so the driver returns the
forces the board was given (to the noise and the count resolution).
"""

from __future__ import annotations

import argparse
import contextlib
import errno
import math
import os
import select
import signal
import socket
import sys
import threading
import time
import tty
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from phri_common import paper
from skin_driver.calibration import CalibrationConfig
from skin_driver.layout import SkinLayout, load_layout, rectangular_patch
from skin_driver.protocol import FLAG_OVERRUN, encode_frame

FloatArray = NDArray[np.float64]
Pattern = Callable[[float], FloatArray]
"""A pressure pattern: time [s] since start → (N,) normal forces [N]."""


@dataclass(frozen=True)
class Faults:
    """Fault injection, each applied independently per frame.

    Attributes:
        garbage_rate: probability of sending 1…``garbage_max`` random bytes before a frame.
        garbage_max: longest garbage burst [bytes].
        bitflip_rate: probability of flipping one random bit of a frame.
        drop_rate: probability of not sending a frame (its sequence number is used up).
        disconnect_every: the port disappears every this many seconds (0 = never) [s].
        disconnect_duration: how long it stays away [s].
    """

    garbage_rate: float = 0.0
    garbage_max: int = 64
    bitflip_rate: float = 0.0
    drop_rate: float = 0.0
    disconnect_every: float = 0.0
    disconnect_duration: float = 1.0

    def __post_init__(self) -> None:
        for name in ("garbage_rate", "bitflip_rate", "drop_rate"):
            if not 0.0 <= getattr(self, name) <= 1.0:
                raise ValueError(f"{name} must be a probability in [0, 1]")
        if self.garbage_max < 1 or self.disconnect_every < 0 or self.disconnect_duration < 0:
            raise ValueError("garbage_max ≥ 1, disconnect_every ≥ 0, disconnect_duration ≥ 0")


@dataclass
class BoardCounters:
    """What a board sent (ground truth for tests)."""

    frames: int = 0
    dropped: int = 0
    garbage_bursts: int = 0
    bitflips: int = 0


class SimBoard:
    """One simulated board: forces → counts → protocol frames, with optional faults.

    Args:
        board_id: 0…255.
        layout: the patch (its gains and offsets invert the driver's calibration); or
        size: taxel count when no layout is given (default gain and offset).
        noise_counts: standard deviation of the ADC noise [count].
        drift_rate: common-mode zero drift of every taxel [N/s] (to exercise compensation).
        faults: fault injection.
        seed: random seed (same seed → same bytes).
        noise_bank: 0: fresh noise every frame; K > 0: the noise of a frame is one of K frames
            drawn at the start, circularly shifted by a random offset (the same σ, ≈ 10× less
            CPU at 10,000 taxels: benchmarks whose boards stand in for hardware, which costs
            the host nothing).
    """

    def __init__(
        self,
        board_id: int,
        layout: SkinLayout | None = None,
        *,
        size: int | None = None,
        noise_counts: float = 2.0,
        drift_rate: float = 0.0,
        faults: Faults | None = None,
        seed: int = 0,
        noise_bank: int = 0,
    ) -> None:
        if layout is None and size is None:
            raise ValueError("give a layout or a size")
        n = layout.size if layout is not None else int(size or 0)
        defaults = CalibrationConfig()
        gains = None if layout is None else layout.gains
        offsets = None if layout is None else layout.offsets
        self.board_id = board_id
        self.size = n
        self.gains = np.full(n, defaults.default_gain) if gains is None else gains.copy()
        self.offsets = np.full(n, defaults.default_offset) if offsets is None else offsets.copy()
        self.noise_counts = noise_counts
        self.drift_rate = drift_rate
        self.faults = faults or Faults()
        self.counters = BoardCounters()
        self.sequence = 0
        self._rng = np.random.default_rng(seed)
        self._inv_gain = np.where(self.gains > 0, 1.0 / np.maximum(self.gains, 1e-300), 0.0)
        if noise_bank < 0:
            raise ValueError(f"noise_bank must be ≥ 0 frames, got {noise_bank}")
        self._noise_bank = (self._rng.normal(0.0, noise_counts, (noise_bank, n))
                            if noise_bank and noise_counts > 0 else None)

    def counts(self, forces: FloatArray, t: float) -> NDArray[np.uint16]:
        """Raw counts for ``forces`` (N,) [N] at board time ``t`` [s]."""
        forces = np.asarray(forces, dtype=np.float64)
        if forces.shape != (self.size,):
            raise ValueError(f"forces must have shape ({self.size},), got {forces.shape}")
        # In place, and nan_to_num only when needed: the same counts at half the cost (the
        # boards are the benchmarks' test rig and must not be what limits them).
        value = forces + self.drift_rate * t
        value *= self._inv_gain
        value += self.offsets
        if self._noise_bank is not None:
            bank = self._noise_bank
            shift = int(self._rng.integers(self.size))
            value += np.roll(bank[self._rng.integers(len(bank))], shift)
        elif self.noise_counts > 0:
            value += self._rng.normal(0.0, self.noise_counts, self.size)
        if not np.isfinite(value).all():
            value = np.nan_to_num(value)
        np.rint(value, out=value)
        return np.clip(value, 0, 65535, out=value).astype("<u2")

    def frame(self, forces: FloatArray, t: float, *, overrun: bool = False) -> bytes:
        """Bytes to send for one sample: a frame, with faults applied (maybe only garbage)."""
        counts = self.counts(forces, t)
        seq = self.sequence
        self.sequence = (self.sequence + 1) % 65536
        f = self.faults
        rng = self._rng
        prefix = b""
        if f.garbage_rate and rng.random() < f.garbage_rate:
            self.counters.garbage_bursts += 1
            prefix = rng.integers(0, 256, int(rng.integers(1, f.garbage_max + 1))).astype(
                np.uint8
            ).tobytes()
        if f.drop_rate and rng.random() < f.drop_rate:
            self.counters.dropped += 1
            return prefix
        data = encode_frame(
            self.board_id,
            seq,
            counts,
            board_time_us=int(t * 1e6),
            flags=FLAG_OVERRUN if overrun else 0,
        )
        if f.bitflip_rate and rng.random() < f.bitflip_rate:
            self.counters.bitflips += 1
            buf = bytearray(data)
            bit = int(rng.integers(0, len(buf) * 8))
            buf[bit // 8] ^= 1 << (bit % 8)
            data = bytes(buf)
        else:
            self.counters.frames += 1
        return prefix + data


# ---------------------------------------------------------------------------------- patterns


def press_pattern(
    layout: SkinLayout,
    *,
    force: float = 5.0,
    radius: float = 0.02,
    period: float = 2.0,
    duty: float = 0.5,
    center: Sequence[float] | None = None,
) -> Pattern:
    """A round press of total ``force`` [N] over taxels within ``radius`` [m] of ``center``.

    On for ``duty · period`` seconds, then off (``period = 0``: always on). The force is spread
    evenly over the taxels inside the radius (at least the nearest one).
    """
    c = layout.positions.mean(axis=0) if center is None else np.asarray(center, dtype=float)
    dist = np.linalg.norm(layout.positions - c, axis=1)
    inside = dist <= radius
    if not inside.any():
        inside[np.argmin(dist)] = True
    on = np.where(inside, force / np.count_nonzero(inside), 0.0)
    off = np.zeros(layout.size)

    def pattern(t: float) -> FloatArray:
        if period <= 0 or (t % period) < duty * period:
            return on
        return off

    return pattern


def pressed_block(count: int, fraction: float, rng: np.random.Generator) -> FloatArray:
    """Taxel forces [N] of one synthetic frame: a block of ``fraction`` of the taxels pressed.

    Every taxel gets noise uniform in [0, 0.02) N (below the paper's σ_t = 0.05 N); a block
    of ``max(1, ⌊fraction · count⌋)`` consecutive taxels at a random start gets
    U[0.1, 1.0) N each. Benchmarks use it for contact estimation loads.
    """
    if count < 1 or not 0.0 <= fraction <= 1.0:
        raise ValueError(
            f"pressed_block needs count ≥ 1 and fraction in [0, 1], got {count}, {fraction}"
        )
    forces = rng.uniform(0.0, 0.02, count)
    pressed = max(1, int(fraction * count))
    start = int(rng.integers(0, count - pressed + 1))
    forces[start : start + pressed] = rng.uniform(0.1, 1.0, pressed)
    return forces


def replay_pattern(recording: FloatArray, rate: float, loop: bool = True) -> Pattern:
    """Replay a (T, N) array of forces [N] sampled at ``rate`` [Hz]."""
    rec = np.asarray(recording, dtype=np.float64)
    if rec.ndim != 2 or rec.shape[0] < 1:
        raise ValueError(f"a recording must be (T, N), got {rec.shape}")

    def pattern(t: float) -> FloatArray:
        k = int(t * rate)
        k = k % rec.shape[0] if loop else min(k, rec.shape[0] - 1)
        return rec[k]

    return pattern


# --------------------------------------------------------------------------------- endpoints


class Endpoint(Protocol):
    def write(self, data: bytes) -> None: ...
    def close(self) -> None: ...


class PtyEndpoint:
    """The board side of a pseudo-terminal; the driver opens :attr:`path` (or ``link``).

    Writes never block longer than ``write_timeout``: like a UART, the board does not wait for
    a listener; what does not fit is dropped (counted in :attr:`overflows`).
    """

    def __init__(self, link: str | Path | None = None, write_timeout: float = 0.01) -> None:
        self._master, self._slave = os.openpty()
        # Raw mode before anyone opens it: no echo, no CR/LF translation of binary data.
        tty.setraw(self._slave)
        os.set_blocking(self._master, False)
        self.path = os.ttyname(self._slave)
        self.link = None if link is None else Path(link)
        self.write_timeout = write_timeout
        self.overflows = 0
        if self.link is not None:
            tmp = self.link.with_name(self.link.name + f".tmp{os.getpid()}")
            with contextlib.suppress(FileNotFoundError):
                tmp.unlink()
            tmp.symlink_to(self.path)
            tmp.replace(self.link)

    def write(self, data: bytes) -> None:
        if not _write_within(self._send, self._master, data, self.write_timeout):
            self.overflows += 1

    def _send(self, view: memoryview) -> int:
        try:
            return os.write(self._master, view)
        except OSError as err:  # EIO: nobody has the pty open yet; wait as for a full one
            if err.errno == errno.EIO:
                raise BlockingIOError(errno.EAGAIN, "no reader") from err
            raise

    def close(self) -> None:
        for fd in (self._master, self._slave):
            with contextlib.suppress(OSError):
                os.close(fd)
        if self.link is not None and self.link.is_symlink():
            with contextlib.suppress(OSError):
                if os.readlink(self.link) == self.path:
                    self.link.unlink()


class TcpEndpoint:
    """The board as a TCP server on ``host`` (a skin board on Ethernet); the driver opens
    :attr:`path`, ``socket://HOST:PORT``. One driver at a time: a new connection replaces the
    old one. As on the pty, writes never block longer than ``write_timeout`` and what does not
    fit is dropped (:attr:`overflows`); frames sent while no driver is connected are not heard
    (:attr:`unheard`). ``send_buffer`` [bytes] asks the kernel for a send buffer of several
    frames (it caps the request at ``net.core.wmem_max``): a pty holds about 20 KB, one
    10,000-taxel frame, and hands it to the reader 4,095 bytes a read, so a board on a pty
    waits for the reader within almost every frame."""

    def __init__(self, host: str = "127.0.0.1", port: int = 0, write_timeout: float = 0.01,
                 send_buffer: int = 1 << 22) -> None:
        self._server = socket.create_server((host, port))
        self._server.setblocking(False)
        bound_host, bound_port = self._server.getsockname()[:2]
        self.path = f"socket://{bound_host}:{bound_port}"
        self.write_timeout = write_timeout
        self.send_buffer = send_buffer
        self.overflows = 0
        self.unheard = 0
        self._conn: socket.socket | None = None

    @property
    def connected(self) -> bool:
        """A driver is connected (accepts a waiting connection first)."""
        self._accept()
        return self._conn is not None

    def _accept(self) -> None:
        try:
            conn, _ = self._server.accept()
        except (BlockingIOError, OSError):
            return
        conn.setblocking(False)
        conn.setsockopt(socket.SOL_SOCKET, socket.SO_SNDBUF, self.send_buffer)
        conn.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self.drop_connection()
        self._conn = conn

    def write(self, data: bytes) -> None:
        self._accept()
        conn = self._conn
        if conn is None:
            self.unheard += 1
            return
        try:
            if not _write_within(conn.send, conn.fileno(), data, self.write_timeout):
                self.overflows += 1
        except (BrokenPipeError, ConnectionResetError):  # the driver went away
            self.drop_connection()

    def drop_connection(self) -> None:
        """Close the driver's connection (as a board's link going down); the server stays."""
        if self._conn is not None:
            with contextlib.suppress(OSError):
                self._conn.close()
            self._conn = None

    def close(self) -> None:
        self.drop_connection()
        with contextlib.suppress(OSError):
            self._server.close()


def _write_within(send: Callable[[memoryview], int], fd: int, data: bytes,
                  timeout: float) -> bool:
    """Write ``data`` through the non-blocking ``send`` (bytes taken per call) on ``fd`` within
    ``timeout`` [s]; False when the rest did not fit in time and was dropped."""
    view = memoryview(data)
    deadline = time.monotonic() + timeout
    while view:
        try:
            view = view[send(view):]
            continue
        except BlockingIOError:
            pass
        left = deadline - time.monotonic()
        if left <= 0:
            return False
        select.select([], [fd], [], left)
    return True


class UrlEndpoint:
    """The board writing to any pyserial URL (a real tty, ``socket://`` …)."""

    def __init__(self, url: str, baudrate: int = 2_000_000) -> None:
        import serial

        self._port = serial.serial_for_url(url, baudrate=baudrate, write_timeout=1.0)
        self.path = url

    def write(self, data: bytes) -> None:
        self._port.write(data)

    def close(self) -> None:
        self._port.close()


# -------------------------------------------------------------------------------- the runner


@dataclass
class RunStats:
    frames_sent: int = 0
    late: int = 0
    disconnects: int = 0


def run_boards(
    open_endpoint: Callable[[], Endpoint],
    boards: Sequence[tuple[SimBoard, Pattern]],
    rate: float,
    stop: threading.Event,
    *,
    duration: float = 0.0,
    on_open: Callable[[Endpoint], None] | None = None,
    on_sent: Callable[[int, int, int], None] | None = None,
) -> RunStats:
    """Send one frame per board every ``1/rate`` s until ``stop`` is set or ``duration`` passes.

    The schedule is absolute (no accumulated jitter); a sample more than one period late is
    skipped and the next frame carries the overrun flag. ``on_sent(board_id, sequence,
    time_ns)`` is called after each frame's last byte was written (benchmarks use it).
    Periodic disconnects (``Faults.disconnect_every`` of the first board) close the endpoint
    and open a new one after ``disconnect_duration``.
    """
    if not (rate > 0 and math.isfinite(rate)):
        raise ValueError(f"rate must be a positive frequency [Hz], got {rate}")
    stats = RunStats()
    period = 1.0 / rate
    faults = boards[0][0].faults if boards else Faults()
    endpoint = open_endpoint()
    if on_open is not None:
        on_open(endpoint)
    t0 = time.monotonic()
    next_disconnect = t0 + faults.disconnect_every if faults.disconnect_every > 0 else math.inf
    k = 0
    overrun = False
    try:
        while not stop.is_set():
            due = t0 + k * period
            now = time.monotonic()
            if duration > 0 and now - t0 >= duration:
                break
            if now >= next_disconnect:
                endpoint.close()
                stats.disconnects += 1
                if stop.wait(faults.disconnect_duration):
                    return stats
                endpoint = open_endpoint()
                if on_open is not None:
                    on_open(endpoint)
                next_disconnect = time.monotonic() + faults.disconnect_every
                continue
            if due > now:
                stop.wait(due - now)
                continue
            if now - due > period:
                skipped = int((now - due) / period)
                k += skipped
                stats.late += skipped
                overrun = True
                continue
            t = due - t0
            for board, pattern in boards:
                endpoint.write(board.frame(pattern(t), t, overrun=overrun))
                if on_sent is not None:
                    on_sent(board.board_id, (board.sequence - 1) % 65536, time.time_ns())
                stats.frames_sent += 1
            overrun = False
            k += 1
    finally:
        endpoint.close()
    return stats


def _parse_args(argv: Sequence[str] | None) -> argparse.Namespace:
    p = argparse.ArgumentParser(
        prog="sim_skin_board",
        description="Simulated phri skin board(s): protocol v1 frames into a pty or a URL.",
    )
    p.add_argument("--port", help="pyserial URL to write to (default: create a pty)")
    p.add_argument("--listen", metavar="[HOST:]PORT",
                   help="serve the frames as a TCP server (an Ethernet board; the driver opens "
                        "socket://HOST:PORT; HOST defaults to 127.0.0.1, PORT 0 picks a free "
                        "one) instead of a pty")
    p.add_argument("--link", help="keep a symlink at this path pointing to the pty")
    p.add_argument("--layout", action="append", default=[],
                   help="layout file, one per board (board ids 0, 1, …)")
    p.add_argument("--boards", type=int, default=1, help="boards when no --layout is given")
    p.add_argument("--taxels", type=int, default=256, help="taxels per board without --layout")
    p.add_argument("--first-board-id", type=int, default=0)
    p.add_argument("--rate", type=float, default=paper.SKIN_RATE_HZ,
                   help="frames per second per board [Hz] (paper III-A: 500)")
    p.add_argument("--duration", type=float, default=0.0, help="seconds to run (0 = forever)")
    p.add_argument("--force", type=float, default=5.0, help="press force [N]")
    p.add_argument("--radius", type=float, default=0.02, help="press radius [m]")
    p.add_argument("--period", type=float, default=2.0, help="press period [s] (0 = held)")
    p.add_argument("--replay", help=".npy file of (T, N) forces [N] to replay at --rate")
    p.add_argument("--noise", type=float, default=2.0, help="ADC noise σ [count]")
    p.add_argument("--drift", type=float, default=0.0, help="common-mode drift [N/s]")
    p.add_argument("--garbage-rate", type=float, default=0.0)
    p.add_argument("--bitflip-rate", type=float, default=0.0)
    p.add_argument("--drop-rate", type=float, default=0.0)
    p.add_argument("--disconnect-every", type=float, default=0.0, help="[s], 0 = never")
    p.add_argument("--disconnect-duration", type=float, default=1.0, help="[s]")
    p.add_argument("--seed", type=int, default=0)
    return p.parse_args(argv)


def main(argv: Sequence[str] | None = None) -> int:
    """Console entry point ``sim_skin_board``."""
    args = _parse_args(argv)
    faults = Faults(
        garbage_rate=args.garbage_rate,
        bitflip_rate=args.bitflip_rate,
        drop_rate=args.drop_rate,
        disconnect_every=args.disconnect_every,
        disconnect_duration=args.disconnect_duration,
    )
    if args.layout:
        layouts = [load_layout(p) for p in args.layout]
    else:
        side = max(1, math.ceil(math.sqrt(args.taxels)))
        layouts = [
            rectangular_patch(f"patch{i}", f"link{i}", side, side)
            for i in range(args.boards)
        ]
    boards: list[tuple[SimBoard, Pattern]] = []
    for i, layout in enumerate(layouts):
        board = SimBoard(
            args.first_board_id + i,
            layout,
            noise_counts=args.noise,
            drift_rate=args.drift,
            faults=faults,
            seed=args.seed + i,
        )
        if args.replay:
            pattern = replay_pattern(np.load(args.replay), args.rate)
        else:
            pattern = press_pattern(
                layout, force=args.force, radius=args.radius, period=args.period
            )
        boards.append((board, pattern))

    def open_endpoint() -> Endpoint:
        if args.port:
            return UrlEndpoint(args.port)
        if args.listen:
            host, _, port = args.listen.rpartition(":")
            return TcpEndpoint(host or "127.0.0.1", int(port))
        return PtyEndpoint(args.link)

    def announce(endpoint: Endpoint) -> None:
        where = getattr(endpoint, "path", "?")
        link = f" (link {args.link})" if args.link else ""
        print(f"sim_skin_board: {len(boards)} board(s) at {args.rate:g} Hz on {where}{link}",
              flush=True)

    stop = threading.Event()
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGTERM, lambda *_: stop.set())
    try:
        stats = run_boards(
            open_endpoint, boards, args.rate, stop, duration=args.duration, on_open=announce
        )
    except KeyboardInterrupt:
        return 0
    except (OSError, ValueError) as err:
        print(f"sim_skin_board: {err}", file=sys.stderr)
        return 1
    print(f"sim_skin_board: sent {stats.frames_sent} frames, {stats.late} late, "
          f"{stats.disconnects} disconnects", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
