"""SerialReader on a pty: every byte delivered, whole writes in one read, loss reported.

Waits are bounded by ``WAIT_S`` only so that a stalled machine fails instead of hanging."""

from __future__ import annotations

import fcntl
import os
import struct
import termios
import threading
import time
from typing import Any

from skin_driver.sim_board import PtyEndpoint, TcpEndpoint
from skin_driver.transport import SerialReader

WAIT_S = 60.0
"""Longest wait for something that must happen (a stalled machine); never a measured time."""


def _wait(condition: object, timeout: float = WAIT_S) -> bool:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if condition():  # type: ignore[operator]
            return True
        time.sleep(0.005)
    return False


def _buffered(fd: int) -> int:
    """Bytes waiting to be read on the tty ``fd`` (FIONREAD)."""
    return int(struct.unpack("i", fcntl.ioctl(fd, termios.FIONREAD, b"\0\0\0\0"))[0])


def test_a_buffered_frame_comes_out_in_one_read() -> None:
    """A 4,020-byte frame (2,000 taxels) waiting whole in the pty comes out in one read of
    everything buffered — not pyserial's one-byte read, an ioctl and the rest, each call a GIL
    hand-off in a process running three readers (transport module docstring). The reader is
    held inside its data handler while each frame is written, until the tty holds all of it."""
    endpoint = PtyEndpoint(write_timeout=WAIT_S)  # the test's writes are never dropped
    probe = os.open(endpoint.path, os.O_RDONLY | os.O_NOCTTY | os.O_NONBLOCK)  # counts only
    chunks: list[bytes] = []
    entered = threading.Semaphore(0)  # the reader is inside on_data
    release = threading.Semaphore(0)  # let it return

    def on_data(chunk: bytes, _t: int) -> None:
        chunks.append(chunk)
        entered.release()
        release.acquire()

    reader = SerialReader(endpoint.path, on_data)
    reader.start()
    frames = [os.urandom(4020) for _ in range(20)]
    try:
        assert _wait(lambda: reader.stats.connected)
        endpoint.write(b"\x01")  # a first byte: the reader then waits in on_data
        assert entered.acquire(timeout=WAIT_S)
        for frame in frames:
            endpoint.write(frame)
            assert _wait(lambda: _buffered(probe) == 4020), _buffered(probe)
            release.release()  # the reader returns and reads what the tty holds
            assert entered.acquire(timeout=WAIT_S)
        release.release()
        assert chunks[1:] == frames  # one read per frame, each read the whole frame
    finally:
        release.release()
        reader.stop()
        os.close(probe)
        endpoint.close()


def test_a_socket_port_is_read_in_whole_chunks_not_byte_by_byte() -> None:
    """``socket://`` (a skin board on Ethernet): 20 frames of 10,000 taxels (20,020 bytes
    each) arrive whole and in order, in a few reads per frame. pyserial's socket ``read`` with
    ``in_waiting`` (which is 0 or 1 for a socket) took one byte per call: 400,400 calls, each a
    ``select`` and a ``recv``, far slower than the board sends."""
    endpoint = TcpEndpoint(write_timeout=WAIT_S)  # the test's writes are never dropped
    chunks: list[bytes] = []
    reader = SerialReader(endpoint.path, lambda chunk, _t: chunks.append(chunk))
    reader.start()
    frames = [os.urandom(20_020) for _ in range(20)]
    try:
        assert _wait(lambda: reader.stats.connected and endpoint.connected)
        for frame in frames:
            endpoint.write(frame)
        assert _wait(lambda: reader.stats.bytes_read == 20 * 20_020), reader.stats
        assert b"".join(chunks) == b"".join(frames)
        assert len(chunks) <= 20 * 4, len(chunks)
    finally:
        reader.stop()
        endpoint.close()


def test_a_shared_poller_serves_a_socket_port_and_reports_its_loss() -> None:
    """The composed node's shared poller reads a ``socket://`` port too (whole chunks on the
    poller's thread); the board closing the connection is a lost port, reported and redialled."""
    from skin_driver.transport import PortPoller

    poller = PortPoller("test-socket-poller")
    endpoint = TcpEndpoint(write_timeout=WAIT_S)
    chunks: list[bytes] = []
    threads: set[str] = set()

    def on_data(chunk: bytes, _t: int) -> None:
        threads.add(threading.current_thread().name)
        chunks.append(chunk)

    reader = SerialReader(endpoint.path, on_data, poller=poller, backoff_initial=0.05,
                          backoff_max=0.1)
    reader.start()
    try:
        assert _wait(lambda: reader.stats.connects == 1 and poller.ports == 1
                     and endpoint.connected)
        frame = os.urandom(20_020)
        endpoint.write(frame)
        assert _wait(lambda: reader.stats.bytes_read == 20_020)
        assert b"".join(chunks) == frame and len(chunks) <= 4 and threads == {
            "test-socket-poller"}
        endpoint.drop_connection()
        assert _wait(lambda: reader.stats.disconnects == 1), reader.stats
        assert "lost" in reader.stats.last_error
        assert _wait(lambda: reader.stats.connects == 2 and endpoint.connected)
    finally:
        reader.stop()
        endpoint.close()


def test_a_closed_pty_is_reported_lost_and_reopened_when_it_returns(tmp_path: object) -> None:
    link = f"{tmp_path}/port"
    endpoint = PtyEndpoint(link)
    errors: list[str] = []
    reader = SerialReader(link, lambda c, t: None, on_error=errors.append,
                          backoff_initial=0.05, backoff_max=0.1)
    reader.start()
    try:
        assert _wait(lambda: reader.stats.connects == 1)
        endpoint.close()
        assert _wait(lambda: reader.stats.disconnects == 1), reader.stats
        assert any("lost" in e for e in errors), errors
        endpoint = PtyEndpoint(link)
        assert _wait(lambda: reader.stats.connects >= 2), reader.stats
    finally:
        reader.stop()
        endpoint.close()


def test_a_shared_poller_reads_every_port_on_one_thread_and_survives_a_lost_one(
    tmp_path: object,
) -> None:
    """Three readers with one PortPoller: every byte of every port arrives, all on the poller's
    thread; one port vanishing is reported and reopened without disturbing the others; when
    the readers stop, the poller's thread ends."""
    from skin_driver.transport import PortPoller

    poller = PortPoller("test-poller")
    links = [f"{tmp_path}/port{i}" for i in range(3)]
    endpoints = [PtyEndpoint(link, write_timeout=WAIT_S) for link in links]  # never dropped
    received: list[list[bytes]] = [[], [], []]
    threads: set[str] = set()

    def on_data(i: int) -> Any:
        def handle(chunk: bytes, _t: int) -> None:
            threads.add(threading.current_thread().name)
            received[i].append(chunk)
        return handle

    readers = [SerialReader(link, on_data(i), poller=poller, backoff_initial=0.05,
                            backoff_max=0.1) for i, link in enumerate(links)]
    for reader in readers:
        reader.start()
    try:
        assert _wait(lambda: all(r.stats.connects == 1 for r in readers) and poller.ports == 3)
        frames = [[os.urandom(4020) for _ in range(20)] for _ in range(3)]
        for k in range(20):
            for endpoint, port_frames in zip(endpoints, frames, strict=True):
                endpoint.write(port_frames[k])
            time.sleep(0.005)
        assert _wait(lambda: all(r.stats.bytes_read == 20 * 4020 for r in readers))
        for i in range(3):
            assert b"".join(received[i]) == b"".join(frames[i])
        assert threads == {"test-poller"}
        endpoints[1].close()
        assert _wait(lambda: readers[1].stats.disconnects == 1), readers[1].stats
        assert "lost" in readers[1].stats.last_error
        endpoints[1] = PtyEndpoint(links[1], write_timeout=WAIT_S)
        assert _wait(lambda: readers[1].stats.connects == 2 and poller.ports == 3)
        endpoints[1].write(b"after")
        endpoints[0].write(b"still")
        assert _wait(lambda: received[1][-1:] == [b"after"] and received[0][-1:] == [b"still"])
    finally:
        for reader in readers:
            reader.stop()
        for endpoint in endpoints:
            endpoint.close()
    assert poller.ports == 0
    assert _wait(lambda: "test-poller" not in {t.name for t in threading.enumerate()})


class FifoRecorder:
    """Stands in for ``set_fifo_priority``: records (thread name, priority); refuses when told."""

    def __init__(self, refuse: bool = False) -> None:
        self.calls: list[tuple[str, int]] = []
        self.refuse = refuse

    def __call__(self, priority: int) -> None:
        self.calls.append((threading.current_thread().name, priority))
        if self.refuse:
            raise PermissionError("Operation not permitted")


def _read_once_with_priority(link: str, endpoint: PtyEndpoint, refuse: bool
                             ) -> tuple[FifoRecorder, list[str]]:
    """A reader at priority 40 reads one write; what it asked for and what it reported."""
    fifo, refusals, data = FifoRecorder(refuse), [], []
    reader = SerialReader(link, lambda c, t: data.append(c), priority=40,
                          on_priority_refused=refusals.append, set_priority=fifo)
    reader.start()
    try:
        assert _wait(lambda: reader.stats.connected)
        endpoint.write(b"frame")
        assert _wait(lambda: b"".join(data) == b"frame")
    finally:
        reader.stop()
    return fifo, refusals


def test_a_reader_asks_for_its_priority_on_its_own_thread_and_reports_a_refusal(
    tmp_path: object,
) -> None:
    """``priority`` > 0: the reading thread (not the caller) asks for SCHED_FIFO once; refused,
    the reader says so through ``on_priority_refused`` and reads on."""
    link = f"{tmp_path}/port"
    endpoint = PtyEndpoint(link, write_timeout=WAIT_S)
    try:
        fifo, refusals = _read_once_with_priority(link, endpoint, refuse=False)
        assert fifo.calls == [(f"serial:{link}", 40)] and refusals == []
        fifo, refusals = _read_once_with_priority(link, endpoint, refuse=True)
        assert fifo.calls == [(f"serial:{link}", 40)] and len(refusals) == 1
        assert "thread_priority: SCHED_FIFO priority 40 refused" in refusals[0]
        assert "normal scheduler" in refusals[0]
    finally:
        endpoint.close()
    fifo = FifoRecorder()
    reader = SerialReader(link, lambda c, t: None, set_priority=fifo)  # priority 0: not asked
    reader.start()
    reader.stop()
    assert fifo.calls == []


def test_a_shared_poller_runs_at_the_highest_priority_its_readers_ask(tmp_path: object) -> None:
    """Readers on one PortPoller asking 10, 30, then 20: the poller's thread asks for 10, then
    30, never lower again; a refusal reaches the readers that asked."""
    from skin_driver.transport import PortPoller

    fifo = FifoRecorder(refuse=True)
    poller = PortPoller("prio-poller", set_priority=fifo)
    links = [f"{tmp_path}/p{i}" for i in range(3)]
    endpoints = [PtyEndpoint(link, write_timeout=WAIT_S) for link in links]
    refusals: list[list[str]] = [[], [], []]
    data: list[bytes] = []
    readers: list[SerialReader] = []
    try:
        for i, (link, priority) in enumerate(zip(links, (10, 30, 20), strict=True)):
            readers.append(SerialReader(link, lambda c, t: data.append(c), poller=poller,
                                        priority=priority, on_priority_refused=refusals[i].append))
            readers[-1].start()
            assert _wait(lambda n=i + 1: poller.ports == n)
            endpoints[i].write(b"%d" % i)  # read on a pass after the registration
            assert _wait(lambda n=i + 1: len(data) == n)
        assert fifo.calls == [("prio-poller", 10), ("prio-poller", 30)]
        assert [len(r) for r in refusals] == [1, 1, 0]
        assert "SCHED_FIFO priority 30 refused" in refusals[1][0]
    finally:
        for reader in readers:
            reader.stop()
        for endpoint in endpoints:
            endpoint.close()
