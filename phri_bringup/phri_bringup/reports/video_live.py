"""The run's video rendered while the run goes on, in a process of its own.

``phri sim`` used to render the MP4 from the recording after the run: on the 2-core machine a
third of the main command's wall time, while the core beside the simulation idled for part of
the run. :class:`LiveVideoSink` is a sink of the observer node (like the recording): its
:meth:`~LiveVideoSink.on_message` keeps the messages of the topics a video shows
(:data:`~phri_bringup.reports.video.VIDEO_TOPICS`) and hands batches of them to a spawned
process, which decodes them into growing tracks (:class:`GrowingTrack`) and renders every frame
whose time lies :data:`LAG_S` behind the newest message (:class:`LiveVideo`). A frame reads the
latest sample at or before its time, and in a lock-step run every message of a control period
arrives before the next period's, so the frames are those :func:`~phri_bringup.reports.video.
render_video` renders from the recording afterwards, pixel for pixel (tested). When the run
ends, :meth:`~LiveVideoSink.close` hands over the end and returns at once; the process renders
the frames left while the command draws the panels, and :meth:`~LiveVideoSink.finish` waits for
the file.

The process runs at a lower CPU priority (:data:`NICE`): the simulation sets the pace, the video
takes the time it leaves. It ignores Ctrl-C (the command stops cleanly and cancels it), ends on
SIGTERM (multiprocessing's clean-up at an unexpected exit) and when its parent is gone.
"""

from __future__ import annotations

import bisect
import functools
import math
import multiprocessing
import os
import signal
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from phri_bringup.observer.recording_process import Message, MessageBatches, received_batches
from phri_bringup.reports.video import (
    VIDEO_TOPICS,
    FrameRenderer,
    VideoOptions,
    VideoUnavailable,
    decode_record,
    frame_count,
    frame_time,
    open_writer,
)

LAG_S = 0.5
"""A frame is rendered once a message [s] this much later than the frame has arrived: the
latest samples at the frame's time are in by then (a lock-step period is 10 ms)."""
NICE = 10
"""Niceness added to the video process: the simulation is the command's critical path."""


class GrowingTrack:
    """A signal that grows in time order: sample times [s] and values; :meth:`at` = latest
    sample ≤ t (as :class:`~phri_bringup.reports.video.Track`)."""

    def __init__(self) -> None:
        self.t: list[float] = []
        self.v: list[Any] = []

    def append(self, t: float, value: Any) -> None:
        self.t.append(t)
        self.v.append(value)

    def at(self, t: float) -> Any:
        i = bisect.bisect_right(self.t, t) - 1
        return self.v[i] if i >= 0 else None


class LiveVideo:
    """Frames of the video of signals that arrive in time order (module docstring), without
    processes or files: :meth:`add` samples, take :meth:`ready` frames, and at the end
    :meth:`rest`. The renderer starts with the first joint state (the video's time origin)."""

    def __init__(self, opts: VideoOptions) -> None:
        self.opts = opts
        self.tracks: dict[str, GrowingTrack] = {}
        self.renderer: FrameRenderer | None = None
        self.next_frame = 0
        self.newest = -np.inf

    def add(self, topic: str, t: float, value: Any) -> None:
        """A sample of ``topic`` at ``t`` [s]."""
        self.tracks.setdefault(topic, GrowingTrack()).append(t, value)
        self.newest = max(self.newest, t)

    def ready(self) -> Iterator[NDArray[np.uint8]]:
        """The frames not rendered yet whose time lies :data:`LAG_S` or more before the newest
        sample."""
        return self._until(lambda i, r: r.time_of(i) <= self.newest - LAG_S)

    def rest(self) -> Iterator[NDArray[np.uint8]]:
        """The frames left, up to the video's length (:func:`~phri_bringup.reports.video.
        frame_count` of everything received)."""
        if "/joint_states" not in self.tracks:
            return iter(())
        n = frame_count(self.tracks, self.opts)
        return self._until(lambda i, _r: i < n)

    def _until(self, due: Callable[[int, FrameRenderer], bool]
               ) -> Iterator[NDArray[np.uint8]]:
        if self.renderer is None:
            if "/joint_states" not in self.tracks:
                return
            self.renderer = FrameRenderer(self.tracks, self.opts)
        while due(self.next_frame, self.renderer):
            frame = self.renderer.frame(self.renderer.time_of(self.next_frame))
            self.next_frame += 1
            yield frame

    def close(self) -> None:
        """Release the renderer's GL context."""
        if self.renderer is not None:
            self.renderer.close()
            self.renderer = None


class FrameDecimation:
    """The messages a video needs (module docstring): a frame shows each topic's latest sample
    at or before its time, so a message is needed only if a frame time lies between its stamp
    and the next message's on its topic. :meth:`offer` holds each topic's newest message until
    the next one decides; a held message older than half :data:`LAG_S` than the newest offered
    goes on anyway (a topic that falls silent keeps its last sample); :meth:`flush` gives the
    held ones at the end. Frame times start at the first ``/joint_states``; before it, every
    message goes on. [about 15 of a topic's 100 messages per second at 15 fps]"""

    def __init__(self, opts: VideoOptions) -> None:
        self.opts = opts
        self.t0: float | None = None
        self.held: dict[str, Message] = {}
        self.newest = -np.inf

    def offer(self, message: Message) -> list[Message]:
        """``message`` is held; returns the held messages that go on now, in arrival order."""
        topic, stamp = message[0], message[3] * 1e-9
        if self.t0 is None and topic == "/joint_states":
            self.t0 = stamp
        self.newest = max(self.newest, stamp)
        out = []
        previous = self.held.pop(topic, None)
        if previous is not None and self._needed(previous[3] * 1e-9, stamp):
            out.append(previous)
        for other, held in list(self.held.items()):
            if self.newest - held[3] * 1e-9 >= 0.5 * LAG_S:
                out.append(self.held.pop(other))
        self.held[topic] = message
        return out

    def flush(self) -> list[Message]:
        """The held messages (the last samples), in arrival order of their topics."""
        out, self.held = list(self.held.values()), {}
        return out

    def _needed(self, stamp: float, next_stamp: float) -> bool:
        """True if a frame time lies in [``stamp``, ``next_stamp``) [s] (or no frame time is
        known yet)."""
        if self.t0 is None or next_stamp < stamp:
            return True
        step = self.opts.speed / self.opts.fps
        i = max(0, math.ceil((stamp - self.t0) / step))
        # the same float expression as the frames' times: the first frame at or after stamp
        while i > 0 and frame_time(self.t0, i - 1, self.opts) >= stamp:
            i -= 1
        while frame_time(self.t0, i, self.opts) < stamp:
            i += 1
        return frame_time(self.t0, i, self.opts) < next_stamp


class LiveVideoSink:
    """The run's MP4 at ``output``, rendered beside the run (module docstring). ``close`` hands
    over the end without waiting; ``finish`` waits and returns the path; ``cancel`` stops the
    rendering and removes the partial file."""

    def __init__(self, output: str | Path, options: VideoOptions | None = None) -> None:
        self.output = Path(output)
        self.output.parent.mkdir(parents=True, exist_ok=True)
        self._needed = FrameDecimation(options or VideoOptions())
        ctx = multiprocessing.get_context("spawn")
        self._batches = MessageBatches(ctx)
        self._result, child = ctx.Pipe(duplex=False)
        self._process = ctx.Process(target=render_from_queue, name="phri-video",
                                    args=(self._batches.queue, str(self.output),
                                          options or VideoOptions(), os.getpid(), child),
                                    daemon=True)
        self._process.start()
        child.close()
        self.closed = False

    def on_message(self, topic: str, type_name: str, raw: bytes, stamp_ns: int) -> None:
        if self.closed or topic not in VIDEO_TOPICS:
            return
        self._batches.add(self._needed.offer((topic, type_name, bytes(raw), stamp_ns)))

    def close(self) -> None:
        """Hand over what is left and the end of the run (idempotent; does not wait)."""
        if self.closed:
            return
        self.closed = True
        self._batches.add(self._needed.flush())
        self._batches.end()

    def finish(self) -> Path:
        """Wait until the video is complete; return its path.

        Raises:
            VideoUnavailable: no offscreen OpenGL or no ffmpeg here (the message says which).
            RuntimeError: the rendering failed (the message says how).
        """
        self.close()
        try:
            status, text = self._result.recv()
        except EOFError:
            status, text = "error", f"the video process ended (exit code {self._process.exitcode})"
        self._process.join()
        if status == "unavailable":
            raise VideoUnavailable(text)
        if status != "ok":
            raise RuntimeError(f"video {self.output}: {text}")
        return self.output

    def cancel(self) -> None:
        """Stop rendering (the run was stopped) and remove the partial video."""
        self.closed = True
        self._batches.queue.cancel_join_thread()
        if self._process.is_alive():
            self._process.kill()  # its encoder ends with its input
        self._process.join()
        self.output.unlink(missing_ok=True)


def render_from_queue(source: Any, output: str, opts: VideoOptions, parent: int,
                      result: Any) -> None:
    """The video process: batches of messages from ``source`` into a :class:`LiveVideo` and an
    encoder until ``None`` arrives (then the frames left) or the process ``parent`` is gone;
    sends ``(status, text)`` through ``result``: ``ok``, ``unavailable`` or ``error``. After a
    failure it still drains ``source``, so the run never waits on a full pipe."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the command decides (it cancels the video)
    os.nice(NICE)
    os.environ.setdefault("MUJOCO_GL", "egl")
    live = LiveVideo(opts)
    encoder = _Encoder(Path(output), opts)
    failure: tuple[str, str] | None = None
    for batch in received_batches(source, parent):
        if failure is None:
            failure = encoder.guard(functools.partial(_add_batch, live, encoder, batch))
    if os.getppid() != parent:  # nobody to hand the video to
        return
    if failure is None:
        failure = encoder.guard(lambda: encoder.send_all(live.rest()))
    live.close()
    if failure is None:
        failure = encoder.guard(encoder.close)
    result.send(failure or ("ok", output))
    result.close()


def _add_batch(live: LiveVideo, encoder: _Encoder, batch: list[Message]) -> None:
    for topic, type_name, raw, stamp_ns in batch:
        live.add(topic, stamp_ns * 1e-9, decode_record(topic, type_name, raw))
    encoder.send_all(live.ready())


class _Encoder:
    """The MP4 encoder, opened with the first frame; :meth:`guard` turns a failure into the
    ``(status, text)`` the process reports."""

    def __init__(self, output: Path, opts: VideoOptions) -> None:
        self.output, self.opts = output, opts
        self.writer: Any = None

    def send_all(self, frames: Iterator[NDArray[np.uint8]]) -> None:
        for frame in frames:
            if self.writer is None:
                self.writer = open_writer(self.output, self.opts)
            self.writer.send(frame)

    def close(self) -> None:
        if self.writer is not None:
            self.writer.close()
            self.writer = None

    def guard(self, work: Callable[[], None]) -> tuple[str, str] | None:
        try:
            work()
        except VideoUnavailable as err:
            return "unavailable", str(err)
        except Exception as err:  # reported by the parent, which goes on without a video
            return "error", f"{type(err).__name__}: {err}"
        return None
