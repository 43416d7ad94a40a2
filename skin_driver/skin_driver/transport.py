"""Serial transport: read any pyserial URL on a thread, reconnect with back-off (no rclpy).

``SerialReader`` owns one port. Its thread opens the port (a tty, a pty, ``socket://host:port``,
anything ``serial.serial_for_url`` accepts), hands every chunk it reads to ``on_data`` together
with the time the chunk arrived, and when the device disappears (unplug, the pty's other side
closes, the socket drops) it closes the port and retries with exponential back-off until the
device is back or :meth:`SerialReader.stop` is called. No exception escapes the thread: a failing
``on_data`` is reported through ``on_error`` and reading goes on.

On a POSIX serial device (a tty, a pty) and on ``socket://`` the thread reads the file
descriptor itself: one ``select`` and one ``os.read`` of everything buffered per wake-up.
pyserial's ``read`` with ``in_waiting`` costs a ``select``, a one-byte read, an ``ioctl`` and a
second read for the same data — three extra system calls, each a GIL release and
re-acquisition that other threads of the process (the composed ``skin_contact_node`` runs three
readers) then contend for; on a socket ``in_waiting`` is only 0 or 1, so pyserial's ``read``
took one byte per call. Other URLs (``loop://``, ``rfc2217://``) go through pyserial's
``read``.

Several readers in one process (the composed ``skin_contact_node``) can share a
:class:`PortPoller`: one thread then ``select``s over every open POSIX port and hands each
chunk on, while each reader's own thread only opens, waits and reconnects. Three reader threads
waking per frame and contending for the GIL cost more per frame than one thread serving all
three (docs/benchmarks.md, "Skin driver").
"""

from __future__ import annotations

import contextlib
import os
import select
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import serial
from serial.urlhandler import protocol_socket

from phri_common.periodic import PRIORITY_RANGE, fifo_refusal, set_fifo_priority

READ_CHUNK_MAX = 1 << 16


_REFUSED = ("thread_priority: {}; reading under the normal scheduler (an rtprio limit grants "
            "it: docs/bringup_guide.md, \"Control PC timing\")")
"""What a reader reports when SCHED_FIFO is refused (``{}``: the system's answer)."""


@dataclass
class TransportStats:
    """Counters of one port (monotonic).

    Attributes:
        connected: the port is open now.
        connects: successful opens.
        disconnects: open ports lost to an error.
        failed_opens: open attempts that failed.
        bytes_read: bytes received.
        last_error: text of the most recent error ("" if none).
    """

    connected: bool = False
    connects: int = 0
    disconnects: int = 0
    failed_opens: int = 0
    bytes_read: int = 0
    last_error: str = ""


def _time_ns() -> int:
    return time.time_ns()


class PortPoller:
    """One thread that waits on many POSIX port descriptors and calls each one's handler when
    it is readable (module docstring). The thread runs while at least one port is registered.
    """

    def __init__(self, name: str = "serial-poller", *,
                 set_priority: Callable[[int], None] = set_fifo_priority) -> None:
        self.name = name
        self._set_priority = set_priority
        self._priority = 0
        """The highest ``priority`` a registration asked for (SCHED_FIFO; 0 = normal)."""
        self._applied = 0
        self._refused: list[Callable[[str], None]] = []
        self._handlers: dict[int, Callable[[], None]] = {}
        self._cond = threading.Condition()
        self._passes = 0
        self._thread: threading.Thread | None = None
        self._wake_r, self._wake_w = os.pipe()
        os.set_blocking(self._wake_r, False)

    @property
    def ports(self) -> int:
        """Number of registered descriptors."""
        with self._cond:
            return len(self._handlers)

    def add(self, fd: int, handler: Callable[[], None], *, priority: int = 0,
            on_refused: Callable[[str], None] | None = None) -> None:
        """Call ``handler()`` on the poller thread whenever ``fd`` is readable. ``priority``
        1–99 asks for the thread to run under SCHED_FIFO at (at least) that priority, as
        :class:`SerialReader`'s own thread would; a refusal is told to ``on_refused`` from the
        poller thread, which then goes on under the normal scheduler."""
        with self._cond:
            self._handlers[fd] = handler
            if priority > self._priority:
                self._priority = priority
                if on_refused is not None:
                    self._refused.append(on_refused)
            if self._thread is None:
                self._thread = threading.Thread(target=self._run, name=self.name, daemon=True)
                self._thread.start()
        os.write(self._wake_w, b"\0")

    def remove(self, fd: int, timeout: float = 1.0) -> None:
        """Stop serving ``fd``; from another thread, return only once no handler call for it
        can still be running (so the caller may close it)."""
        with self._cond:
            self._handlers.pop(fd, None)
            if self._thread is None or threading.current_thread() is self._thread:
                return
            target = self._passes + 1
        os.write(self._wake_w, b"\0")
        with self._cond:
            self._cond.wait_for(lambda: self._passes >= target or self._thread is None, timeout)

    def _run(self) -> None:
        while True:
            with self._cond:
                if not self._handlers:
                    self._thread = None
                    self._cond.notify_all()
                    return
                fds = list(self._handlers)
                wanted, refused = self._priority, self._refused
                self._refused = []
            if wanted > self._applied:
                self._applied = wanted
                message = fifo_refusal(wanted, self._set_priority)
                for report in refused if message else []:
                    report(_REFUSED.format(message))
            try:
                ready, _, _ = select.select([self._wake_r, *fds], [], [], 0.1)
            except OSError:  # a descriptor closed under us: the next pass has a fresh list
                ready = []
            if self._wake_r in ready:
                with contextlib.suppress(BlockingIOError):
                    os.read(self._wake_r, 4096)
            for fd in ready:
                with self._cond:
                    handler = self._handlers.get(fd) if fd != self._wake_r else None
                if handler is not None:
                    handler()
            with self._cond:
                self._passes += 1
                self._cond.notify_all()


class SerialReader:
    """Reads a pyserial URL on its own thread and reconnects when the device disappears.

    Args:
        url: pyserial URL or device path.
        on_data: called on the reader thread with ``(chunk, arrival_ns)`` for every read.
        baudrate: line rate [bit/s] (ignored by ptys, sockets and USB CDC devices).
        read_timeout: longest a read blocks, so :meth:`stop` is honoured promptly [s].
        backoff_initial: first wait after a failure [s]; doubles on every further failure.
        backoff_max: longest wait between open attempts [s].
        clock: arrival-time source [ns] (the node passes its ROS clock).
        on_connect: called with no argument after each successful open (e.g. reset the parser).
        on_error: called with a message whenever something fails (open, read, on_data).
        open_port: factory for the port object (tests substitute a fake).
        poller: read a POSIX port on this shared thread instead of this reader's own.
        priority: 1–99: read under SCHED_FIFO at this priority (the poller's thread at the
            highest its readers ask); 0: the normal scheduler.
        on_priority_refused: called with a message when the system refuses it (default
            ``on_error``); the reading goes on under the normal scheduler.
        set_priority: puts the calling thread under SCHED_FIFO (tests substitute a fake).
    """

    def __init__(
        self,
        url: str,
        on_data: Callable[[bytes, int], None],
        *,
        baudrate: int = 2_000_000,
        read_timeout: float = 0.05,
        backoff_initial: float = 0.1,
        backoff_max: float = 2.0,
        clock: Callable[[], int] = _time_ns,
        on_connect: Callable[[], None] | None = None,
        on_error: Callable[[str], None] | None = None,
        open_port: Callable[..., Any] = serial.serial_for_url,
        poller: PortPoller | None = None,
        priority: int = 0,
        on_priority_refused: Callable[[str], None] | None = None,
        set_priority: Callable[[int], None] = set_fifo_priority,
    ) -> None:
        if not (0 < backoff_initial <= backoff_max):
            raise ValueError("need 0 < backoff_initial <= backoff_max")
        self.url = url
        self.stats = TransportStats()
        self._on_data = on_data
        self._baudrate = baudrate
        self._read_timeout = read_timeout
        self._backoff_initial = backoff_initial
        self._backoff_max = backoff_max
        self._clock = clock
        self._on_connect = on_connect
        self._on_error = on_error
        self._open_port = open_port
        self._poller = poller
        if not PRIORITY_RANGE[0] <= priority <= PRIORITY_RANGE[1]:
            raise ValueError(f"priority must be in [{PRIORITY_RANGE[0]}, {PRIORITY_RANGE[1]}], "
                             f"got {priority!r}")
        self._priority = priority
        self._set_priority = set_priority
        self._on_priority_refused = on_priority_refused or self._report
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._port: Any = None

    def start(self) -> None:
        """Start the reader thread (idempotent)."""
        if self._thread is not None and self._thread.is_alive():
            return
        self._stop.clear()
        self._thread = threading.Thread(target=self._run, name=f"serial:{self.url}", daemon=True)
        self._thread.start()

    def stop(self, timeout: float = 2.0) -> None:
        """Stop the thread and close the port."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout)
            self._thread = None
        self._close()

    @property
    def running(self) -> bool:
        return self._thread is not None and self._thread.is_alive()

    def _report(self, message: str) -> None:
        self.stats.last_error = message
        if self._on_error is not None:
            # A logging failure must not stop the reader.
            with contextlib.suppress(Exception):
                self._on_error(message)

    def _close(self) -> None:
        port, self._port = self._port, None
        self.stats.connected = False
        if port is not None:
            # Closing a vanished device may fail in any way.
            with contextlib.suppress(Exception):
                port.close()

    def _run(self) -> None:
        if self._priority > 0 and self._poller is None:
            message = fifo_refusal(self._priority, self._set_priority)
            if message:
                self._on_priority_refused(_REFUSED.format(message))
        backoff = self._backoff_initial
        while not self._stop.is_set():
            try:
                self._port = self._open_port(
                    self.url, baudrate=self._baudrate, timeout=self._read_timeout
                )
            except Exception as err:  # any open failure means: retry later
                self.stats.failed_opens += 1
                self._report(f"cannot open {self.url}: {err}")
                self._stop.wait(backoff)
                backoff = min(2.0 * backoff, self._backoff_max)
                continue
            self.stats.connected = True
            self.stats.connects += 1
            backoff = self._backoff_initial
            if self._on_connect is not None:
                self._on_connect()
            fd = _posix_fd(self._port)
            if self._poller is not None and fd is not None:
                self._serve_until_error(self._poller, fd)
            else:
                self._read_until_error()
            self._close()
            if not self._stop.is_set():
                self.stats.disconnects += 1
                self._stop.wait(backoff)

    def _read_until_error(self) -> None:
        port = self._port
        fd = _posix_fd(port)
        while not self._stop.is_set():
            try:
                chunk = self._read_fd(fd) if fd is not None else self._read_port(port)
            except Exception as err:  # SerialException, OSError (EIO on unplug), …
                self._report(f"lost {self.url}: {err}")
                return
            self._deliver(chunk)

    def _serve_until_error(self, poller: PortPoller, fd: int) -> None:
        """Let ``poller`` read ``fd`` until the port is lost or :meth:`stop` is called."""
        lost = threading.Event()

        def readable() -> None:
            if lost.is_set():
                return
            try:
                chunk = self._read_fd(fd, wait=False)
            except Exception as err:  # SerialException, OSError (EIO on unplug), …
                self._report(f"lost {self.url}: {err}")
                lost.set()
                poller.remove(fd)
                return
            self._deliver(chunk)

        poller.add(fd, readable, priority=self._priority, on_refused=self._on_priority_refused)
        try:
            while not (lost.is_set() or self._stop.is_set()):
                lost.wait(self._read_timeout)
        finally:
            poller.remove(fd)

    def _deliver(self, chunk: bytes) -> None:
        """Count ``chunk`` and hand it to ``on_data`` (a failing handler is reported)."""
        if not chunk:
            return
        self.stats.bytes_read += len(chunk)
        try:
            self._on_data(chunk, self._clock())
        except Exception as err:  # the reader must outlive a bad handler
            self._report(f"error handling data from {self.url}: {err!r}")

    def _read_port(self, port: Any) -> bytes:
        """Everything buffered (at least one byte, or b"" after the read timeout), through
        pyserial's ``read``."""
        return bytes(port.read(min(max(port.in_waiting, 1), READ_CHUNK_MAX)))

    def _read_fd(self, fd: int, wait: bool = True) -> bytes:
        """Everything buffered on a non-blocking POSIX descriptor, or b"" after the read
        timeout: one ``select`` (not when the caller knows it is readable: ``wait`` false),
        one ``os.read`` (module docstring).

        Raises:
            serial.SerialException: the device is gone (ready but no data: hang-up).
            OSError: the read failed (EIO when the device is unplugged or the pty closed).
        """
        if wait:
            ready, _, _ = select.select([fd], [], [], self._read_timeout)
            if not ready:
                return b""
        try:
            chunk = os.read(fd, READ_CHUNK_MAX)
        except BlockingIOError:
            return b""
        if not chunk:
            raise serial.SerialException("device reports readiness to read but returned no "
                                         "data (device disconnected?)")
        return chunk


def _posix_fd(port: Any) -> int | None:
    """The open, non-blocking file descriptor of a POSIX pyserial port or of a ``socket://``
    port; None for anything else (loop://, test doubles), which is read through pyserial."""
    posix = getattr(serial, "serialposix", None)
    if posix is not None and isinstance(port, posix.Serial):
        fd = getattr(port, "fd", None)
    elif isinstance(port, protocol_socket.Serial):
        fd = port.fileno() if port.is_open else None
    else:
        return None
    if not isinstance(fd, int) or os.get_blocking(fd):
        return None
    return fd
