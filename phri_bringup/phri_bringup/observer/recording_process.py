"""The MCAP recording written by a process of its own (no rclpy: pure multiprocessing).

:class:`~phri_bringup.observer.node.RecordingSink` does real work per message — the taxel
arrays' decimation, the MCAP chunks and their zstd compression, ``/tf`` by forward kinematics
and a pure-Python CDR encoder at 50 Hz — about a quarter of a lock-step run's time when it runs
beside the simulation on the executor's thread. :class:`BackgroundRecordingSink` is the same
sink in a spawned process: the observer node's callback only keeps the message (the taxel
arrays the recording drops are dropped here already, by the same rule) and hands batches of
them to the process through a queue, whose feeder thread writes them to a pipe. The process feeds
them, in order, to a :class:`RecordingSink`; the recording is the same file, message for
message.

The process ignores Ctrl-C and SIGTERM (sent to the whole process group by a terminal or a
``timeout``): it ends when the sink is closed, having closed the recording, or when its parent
is gone.
"""

from __future__ import annotations

import contextlib
import multiprocessing
import os
import queue
import signal
import traceback
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path
from typing import Any

from phri_bringup.observer.bag import clear_previous_recording

BATCH = 256
"""Messages handed to the recording process at once (one pickle, one pipe write)."""
PARENT_POLL_S = 1.0
"""How often [s] an idle recording process checks that its parent still runs."""
Message = tuple[str, str, bytes, int]
"""(topic, type name, CDR bytes, time [ns]): what a sink's ``on_message`` gets."""


class SkinDecimation:
    """Which taxel arrays a recording keeps, per patch topic: ``skin_rate_hz`` frames per
    second of sim time — a frame once 95 % of the period 1 / ``skin_rate_hz`` has passed since
    the last kept one (the 5 % absorbs samples that do not fall on the period exactly; 10 Hz of
    a 100 Hz stream is every tenth frame); every frame with 0."""

    def __init__(self, skin_rate_hz: float) -> None:
        period = 0 if skin_rate_hz <= 0 else round(1e9 / skin_rate_hz)
        self.keep_after = period - period // 20
        self._last: dict[str, int] = {}

    def keep(self, topic: str, stamp_ns: int) -> bool:
        """True if the message on ``topic`` at ``stamp_ns`` is recorded (and remembered)."""
        if not self.keep_after or not topic.startswith("/skin/"):
            return True
        last = self._last.get(topic)
        if last is not None and stamp_ns - last < self.keep_after:
            return False
        self._last[topic] = stamp_ns
        return True


class MessageBatches:
    """Messages handed to a spawned process through a queue of ``ctx``, :data:`BATCH` at a time
    (one pickle, one pipe write); :meth:`end` hands over the rest and the end mark (None).
    :func:`received_batches` is the process's side."""

    def __init__(self, ctx: Any) -> None:
        self.queue: Any = ctx.Queue()
        self._batch: list[Message] = []

    def add(self, messages: Iterable[Message]) -> None:
        self._batch.extend(messages)
        if len(self._batch) >= BATCH:
            self._flush()

    def end(self) -> None:
        self._flush()
        self.queue.put(None)

    def _flush(self) -> None:
        if self._batch:
            self.queue.put(self._batch)
            self._batch = []


def received_batches(source: Any, parent: int) -> Iterator[list[Message]]:
    """The batches a :class:`MessageBatches` queue ``source`` delivers, until its end mark or
    until the process ``parent`` is gone (checked every :data:`PARENT_POLL_S` of silence)."""
    while True:
        try:
            batch = source.get(timeout=PARENT_POLL_S)
        except queue.Empty:
            if os.getppid() != parent:
                return
            continue
        if batch is None:
            return
        yield batch


class BackgroundRecordingSink:
    """A :class:`~phri_bringup.observer.node.RecordingSink` in a process of its own (module
    docstring); the same arguments. ValueError (before the process starts) for a recording
    directory that holds other files; :meth:`close` waits until the recording is complete and
    raises RuntimeError if the process failed.

    ``builder``: a picklable factory of an object with ``add(topic, type_name, raw, t [s])``
    and ``result()`` (e.g. :class:`phri_bringup.reports.plots.RunBuilder`, the panels' series,
    or :class:`~phri_bringup.reports.plots.PanelsBuilder`, which also draws them). Every
    recorded message is added to one in the recording process. Once the recording is closed,
    :meth:`start_building` has its ``result()`` computed there while the caller goes on,
    :meth:`take_built` returns it, and :meth:`discard_built` ends the process without it (a run
    that was stopped)."""

    def __init__(self, directory: str, skin_rate_hz: float = 20.0, tf_rate_hz: float = 50.0,
                 builder: Callable[[], Any] | None = None) -> None:
        clear_previous_recording(Path(directory))
        Path(directory).parent.mkdir(parents=True, exist_ok=True)
        self.directory = directory
        self._skin = SkinDecimation(skin_rate_hz)
        ctx = multiprocessing.get_context("spawn")
        self._batches = MessageBatches(ctx)
        self._series: Any = None
        child: Any = None
        if builder is not None:
            self._series, child = ctx.Pipe()
        self._process = ctx.Process(target=record_from_queue, name="phri-recording",
                                    args=(self._batches.queue, directory, skin_rate_hz, tf_rate_hz,
                                          os.getpid(), child, builder), daemon=True)
        self._process.start()
        if child is not None:
            child.close()
        self.closed = False
        self._built: Any = None
        self._requested = False
        self._joined = False

    def on_message(self, topic: str, type_name: str, raw: bytes, stamp_ns: int) -> None:
        if self.closed or not self._skin.keep(topic, stamp_ns):
            return
        self._batches.add(((topic, type_name, bytes(raw), stamp_ns),))

    def close(self) -> None:
        """Hand over what is left, wait until the recording is closed (idempotent)."""
        if self.closed:
            return
        self.closed = True
        self._batches.end()
        self._batches.queue.close()
        self._batches.queue.join_thread()
        recorded = False
        if self._series is not None:
            with contextlib.suppress(EOFError):  # the process failed: reported below
                recorded = bool(self._series.recv())
        if not recorded:  # no builder, or the recording failed
            self._join()

    def start_building(self) -> None:
        """After :meth:`close`: the recording process computes the builder's result now."""
        self._answer(True)

    def take_built(self) -> Any:
        """After :meth:`close`: the builder's result, waiting for it (None without a builder
        or if building failed: the recording does not depend on it)."""
        self._answer(True)
        if self._series is not None and not self._joined:
            with contextlib.suppress(EOFError):
                self._built = self._series.recv()
            self._join()
        return self._built

    def discard_built(self) -> None:
        """After :meth:`close`: end the recording process without the builder's result."""
        self._answer(False)
        self._join()

    def _answer(self, build: bool) -> None:
        """Tell the recording process, once, whether to compute the builder's result."""
        if self._series is None or self._requested or self._joined:
            return
        self._requested = True
        with contextlib.suppress(OSError):  # the process is gone: _join reports it
            self._series.send(build)

    def _join(self) -> None:
        """Wait for the process to end; RuntimeError if it failed."""
        if self._joined:
            return
        self._joined = True
        self._process.join()
        if self._process.exitcode != 0:
            raise RuntimeError(f"the recording process for {self.directory} failed (exit code "
                               f"{self._process.exitcode}); see its error above")


def record_from_queue(source: Any, directory: str, skin_rate_hz: float, tf_rate_hz: float,
                      parent: int, series: Any = None,
                      builder: Callable[[], Any] | None = None) -> None:
    """The recording process: batches of messages from ``source`` into a RecordingSink until
    ``None`` arrives or the process ``parent`` is gone; with a ``series`` connection, the same
    messages also go to a ``builder()``, whose result is sent through it at the end (None if
    building failed: the recording does not depend on it)."""
    from phri_bringup.observer.node import RecordingSink

    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_IGN)
    sink: Any = RecordingSink(directory, skin_rate_hz=skin_rate_hz, tf_rate_hz=tf_rate_hz)
    if series is not None and builder is not None:
        sink = _SeriesTap(sink, series, builder())
    try:
        for batch in received_batches(source, parent):
            for topic, type_name, raw, stamp_ns in batch:
                sink.on_message(topic, type_name, raw, stamp_ns)
    finally:
        sink.close()


class _SeriesTap:
    """A RecordingSink that also adds every message to ``builder``; when it closes it sends
    through ``conn`` whether the recording was closed intact, then, if the caller asks for it,
    the builder's result (None if building failed)."""

    def __init__(self, sink: Any, conn: Any, builder: Any) -> None:
        self.sink, self.conn, self.builder = sink, conn, builder

    def on_message(self, topic: str, type_name: str, raw: bytes, stamp_ns: int) -> None:
        self.sink.on_message(topic, type_name, raw, stamp_ns)
        if self.builder is not None:
            try:
                self.builder.add(topic, type_name, raw, stamp_ns * 1e-9)
            except Exception:  # the panels read the recording instead
                self.builder = None

    def close(self) -> None:
        recorded = False
        try:
            self.sink.close()
            recorded = True
        finally:
            self.conn.send(recorded)  # the caller goes on once the recording is complete
            if recorded and self._asked():
                self.conn.send(self._result())
            self.conn.close()

    def _asked(self) -> bool:
        """Whether the caller wants the builder's result (no: a stopped run, or it is gone)."""
        try:
            return bool(self.conn.recv())
        except EOFError:
            return False

    def _result(self) -> Any:
        if self.builder is None:
            return None
        try:
            return self.builder.result()
        except Exception:  # the caller draws from the recording instead
            traceback.print_exc()
            return None
