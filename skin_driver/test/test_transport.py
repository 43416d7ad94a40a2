"""SerialReader on a pty: every byte delivered, whole writes in one read, loss reported."""

from __future__ import annotations

import os
import threading
import time

from skin_driver.sim_board import PtyEndpoint
from skin_driver.transport import SerialReader


def _wait(condition: object, timeout: float = 5.0) -> bool:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if condition():  # type: ignore[operator]
            return True
        time.sleep(0.005)
    return False


def test_each_write_arrives_whole_in_about_one_read() -> None:
    """A 4,020-byte frame (2,000 taxels) written while the reader waits comes out of the pty
    in one or two reads — not a one-byte read, an ioctl and the rest, each call a GIL hand-off
    in a process running three readers (transport module docstring)."""
    endpoint = PtyEndpoint()
    chunks: list[bytes] = []
    lock = threading.Lock()

    def on_data(chunk: bytes, _t: int) -> None:
        with lock:
            chunks.append(chunk)

    reader = SerialReader(endpoint.path, on_data)
    reader.start()
    try:
        assert _wait(lambda: reader.stats.connected)
        frames = [os.urandom(4020) for _ in range(40)]
        for frame in frames:
            endpoint.write(frame)
            time.sleep(0.01)  # the reader is waiting when the next frame comes
        assert _wait(lambda: reader.stats.bytes_read == 40 * 4020), reader.stats
        with lock:
            assert b"".join(chunks) == b"".join(frames)
            assert len(chunks) <= 1.5 * len(frames), f"{len(chunks)} reads for 40 writes"
            assert min(len(c) for c in chunks) > 1
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
