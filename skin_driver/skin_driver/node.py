"""``skin_driver_node``: one serial port → one calibrated taxel array topic per skin patch.

Thin node: parameters → :class:`~skin_driver.calibration.CalibrationConfig` and layouts; the
serial thread (:class:`~skin_driver.transport.SerialReader`) feeds the
:class:`~skin_driver.protocol.FrameParser`; each frame goes through its board's
:class:`~skin_driver.calibration.PatchCalibrator` and is published from the serial thread with
``phri_common.taxels.TaxelCloudEncoder`` (publishing there saves the hand-off to the executor;
``bench/bench_skin_driver.py`` measures the latency). The executor only runs the diagnostics and
silence timers, the tare service and parameter services.

Topics: ``skin/<patch>/taxels`` (``sensor_msgs/PointCloud2``, frame = the patch's link, stamp =
the board's sampling time ``board_time_us`` mapped to the node clock by
:class:`~skin_driver.board_clock.BoardClock`, one per board), ``/diagnostics``
(``diagnostic_msgs/DiagnosticArray``).
Services: ``~/tare`` and ``~/reload_layouts`` (``std_srvs/Trigger``). A frame whose taxel
count differs from its patch's layout is refused (counted, reported with both sizes on
diagnostics), never published: a patch's geometry changes only when its layout file is reloaded
(``~/reload_layouts``). Interface: ``docs/skin_driver.md``.
"""

from __future__ import annotations

import sys
import threading
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from diagnostic_msgs.msg import DiagnosticArray
from numpy.typing import NDArray
from rclpy.context import Context
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.publisher import Publisher
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import PointCloud2
from std_srvs.srv import Trigger

from phri_common import paper
from phri_common.params import ParameterValueError, ParamSpec, ParamValue
from phri_common.records import TaxelArray
from phri_common.ros_main import run_nodes
from phri_common.ros_params import declare_parameters
from phri_common.stamps import ns_to_stamp
from phri_common.taxels import TaxelCloudEncoder
from skin_driver.board_clock import BoardClock
from skin_driver.calibration import KERNELS, CalibrationConfig, FloatArray, PatchCalibrator
from skin_driver.diagnostics import BoardSnapshot, PortSnapshot, board_status, port_status
from skin_driver.layout import LayoutError, SkinLayout, load_layout
from skin_driver.protocol import MAX_TAXELS, BoardSequence, Frame, FrameParser
from skin_driver.transport import PortPoller, SerialReader

FrameListener = Callable[[str, TaxelArray], None]
"""Receives (patch name, calibrated taxel array) for every frame (see add_frame_listener)."""

PARAMS: list[ParamSpec] = [
    ParamSpec("port", "/dev/ttyACM0", "pyserial URL or device path of the skin port "
              "(a tty, a pty, socket://host:port)", read_only=True),
    ParamSpec("baudrate", 2_000_000, "serial line rate (ignored by ptys, sockets, USB CDC)",
              unit="bit/s", low=1200, high=100_000_000, read_only=True),
    ParamSpec("board_ids", [0], "board id of each patch on this port (protocol header byte 4); "
              "entry i feeds layout_files[i]", low=0, high=255, min_length=1, read_only=True),
    ParamSpec("layout_files", [""], "layout file of each patch (patch name, link, taxel "
              "geometry, calibration), one per board id", min_length=1, read_only=True),
    ParamSpec("max_taxels", MAX_TAXELS, "largest taxel count the parser accepts in a frame "
              "header (bounds memory)", low=1, high=MAX_TAXELS, read_only=True),
    ParamSpec("filter_window", paper.FILTER_WINDOW, "moving-average window (paper Sec. VI: 10)",
              unit="frames",
              low=1, high=1000, read_only=True),
    ParamSpec("default_gain", 0.0005, "gain of taxels whose layout has no gain column",
              unit="N/count", low=0.0, high=1.0, read_only=True),
    ParamSpec("default_offset", 1000.0, "factory zero of taxels whose layout has no offset "
              "column", unit="count", low=0.0, high=65535.0, read_only=True),
    ParamSpec("tare_frames", 100, "frames averaged for the start-up tare (0 = factory zero); "
              "nothing is published meanwhile", unit="frames", low=0, high=100_000,
              read_only=True),
    ParamSpec("tare_max_shift", 0.5, "a taxel reading more than this above its factory zero "
              "during tare is being touched and keeps the factory zero", unit="N", low=0.0,
              high=1000.0, read_only=True),
    ParamSpec("drift_time_constant", 60.0, "time constant of the zero tracking of untouched "
              "taxels (0 = no drift compensation)", unit="s", low=0.0, high=100_000.0,
              read_only=True),
    ParamSpec("drift_band", 0.03, "deviation from the zero that still counts as untouched; "
              "bounds how much of a slowly growing contact can be absorbed", unit="N", low=0.0,
              high=100.0, read_only=True),
    ParamSpec("release_time_constant", 1.0, "time constant that pulls a zero above the signal "
              "(negative reading) down", unit="s", low=0.001, high=10_000.0, read_only=True),
    ParamSpec("saturation_count", 65535, "raw count at or above which a taxel is saturated",
              unit="count", low=1, high=65535, read_only=True),
    ParamSpec("stuck_time", 5.0, "a raw count unchanged this long masks the taxel as dead "
              "until it changes (0 = off)", unit="s", low=0.0, high=3600.0, read_only=True),
    ParamSpec("silence_timeout", 0.1, "a board without frames this long is declared silent "
              "(its patch is not published; diagnostics ERROR); bytes arriving this long "
              "without an intact frame turn the port status WARN", unit="s", low=0.004,
              high=60.0),
    ParamSpec("diagnostics_period", 1.0, "period of /diagnostics", unit="s", low=0.05,
              high=60.0, read_only=True),
    ParamSpec("reconnect_backoff_initial", 0.1, "first wait before reopening a lost port; "
              "doubles per failure", unit="s", low=0.01, high=10.0, read_only=True),
    ParamSpec("reconnect_backoff_max", 2.0, "longest wait between reopen attempts", unit="s",
              low=0.01, high=60.0, read_only=True),
    ParamSpec("taxel_publish_rate_hz", 0.0, "largest rate at which each patch's taxel array is "
              "published; 0 = every frame. Lower it only when the frames also reach the "
              "estimator directly (skin_contact_node)", unit="Hz", low=0.0, high=10_000.0,
              read_only=True),
    ParamSpec("kernel", KERNELS[1], "how a frame is calibrated: numba (compiled, default) or "
              "numpy (the reference); same forces to rounding", read_only=True),
    ParamSpec("qos_depth", 5, "keep-last depth of the taxel publishers (reliable)",
              unit="messages", low=1, high=1000, read_only=True),
    ParamSpec("thread_priority", 0, "serial reading thread (composed: the shared one, at the "
              "highest its drivers ask): 0 = the normal scheduler, 1–99 = SCHED_FIFO at that "
              "priority (needs an rtprio limit or CAP_SYS_NICE; refused → warning, normal "
              "scheduler)", "-", 0, 99, read_only=True),
]


def _period_s(rate_hz: float) -> float:
    """Publication period [s] of a rate limit [Hz]; 0 (no limit) for a rate of 0."""
    return 1.0 / rate_hz if rate_hz > 0.0 else 0.0


def calibration_config(values: dict[str, ParamValue]) -> CalibrationConfig:
    """Parameter values → calibration settings (pure).

    Raises:
        ParameterValueError: ``kernel`` not one of :data:`~skin_driver.calibration.KERNELS`.
    """
    if values["kernel"] not in KERNELS:
        raise ParameterValueError(f"parameter 'kernel' refused value {values['kernel']!r}: "
                                  f"allowed {', '.join(KERNELS)}")
    return CalibrationConfig(
        default_gain=float(values["default_gain"]),
        default_offset=float(values["default_offset"]),
        filter_window=int(values["filter_window"]),
        tare_frames=int(values["tare_frames"]),
        tare_max_shift=float(values["tare_max_shift"]),
        drift_time_constant=float(values["drift_time_constant"]),
        drift_band=float(values["drift_band"]),
        release_time_constant=float(values["release_time_constant"]),
        saturation_count=int(values["saturation_count"]),
        stuck_time=float(values["stuck_time"]),
        kernel=str(values["kernel"]),
    )


def load_patches(board_ids: Sequence[int], files: Sequence[str]) -> dict[int, SkinLayout]:
    """Board id → layout, refusing mismatched lists, duplicate ids/patches or bad files."""
    if len(board_ids) != len(files):
        raise ParameterValueError(
            f"parameter 'layout_files' needs one file per entry of 'board_ids' "
            f"({len(board_ids)}), got {len(files)}"
        )
    if len(set(board_ids)) != len(board_ids):
        raise ParameterValueError(
            f"parameter 'board_ids' refused value {list(board_ids)}: allowed unique ids in "
            "[0, 255]"
        )
    patches: dict[int, SkinLayout] = {}
    for board, path in zip(board_ids, files, strict=True):
        if not path:
            raise ParameterValueError(
                f"parameter 'layout_files': no layout file for board {board}"
            )
        try:
            patches[int(board)] = load_layout(path)
        except LayoutError as err:
            raise ParameterValueError(f"parameter 'layout_files': {err}") from err
    names = [layout.patch for layout in patches.values()]
    if len(set(names)) != len(names):
        raise ParameterValueError(
            f"parameter 'layout_files' refused: the layouts' patch names {names} must be unique"
        )
    return patches


def reload_patches(
    current: Mapping[int, SkinLayout], board_ids: Sequence[int], files: Sequence[str]
) -> dict[int, SkinLayout]:
    """The layouts of ``files`` read again for a reload (pure but for reading the files): as
    :func:`load_patches`, and each board keeps its patch name and link (its topic and frame).

    Raises:
        ParameterValueError: a file does not load, or a board's patch name or link changed
            (names the board, both names and the file).
    """
    layouts = load_patches(board_ids, files)
    for (board, new), path in zip(layouts.items(), files, strict=True):
        old = current[board]
        if (new.patch, new.link) != (old.patch, old.link):
            raise ParameterValueError(
                f"parameter 'layout_files' refused reloading {path!r}: board {board} is patch "
                f"{old.patch!r} on link {old.link!r}, the file names patch {new.patch!r} on link "
                f"{new.link!r} (a reload keeps each board's patch and link; restart the node to "
                "change them)"
            )
    return layouts


def same_layout(a: SkinLayout, b: SkinLayout) -> bool:
    """Do two layouts hold the same geometry and calibration (bit for bit)?"""
    def same(x: NDArray[Any] | None, y: NDArray[Any] | None) -> bool:
        return (x is None and y is None) or (
            x is not None and y is not None and np.array_equal(x, y))

    return bool(a.patch == b.patch and a.link == b.link and all(
        same(getattr(a, f), getattr(b, f))
        for f in ("positions", "normals", "weights", "gains", "offsets", "dead")))


@dataclass
class _Channel:
    """One board: its patch, calibrator, encoder, publisher and counters."""

    board_id: int
    layout: SkinLayout
    calibrator: PatchCalibrator
    encoder: TaxelCloudEncoder
    publisher: Publisher
    frames: int = 0
    published: int = 0
    size_mismatches: int = 0
    wrong_size: int = 0
    """Taxel count of the last frame refused for its size (0: none yet)."""
    mismatch_logged: bool = False
    last_frame_mono: float = 0.0
    silent: bool = True
    frames_at_last_diag: int = 0
    dropped_at_last_diag: int = 0
    mismatches_at_last_diag: int = 0
    sequence: BoardSequence = field(default_factory=BoardSequence)
    """Sequence gaps of the frames accepted for this board (dropped = gaps only)."""
    clock: BoardClock = field(default_factory=BoardClock)
    next_publish_mono: float = 0.0
    geometry: tuple[FloatArray, FloatArray, FloatArray | None] = field(init=False)
    """Read-only copies of the layout's positions, normals and weights: a TaxelArray built
    from them (and from read-only forces) copies nothing (phri_common.records.frozen)."""

    def __post_init__(self) -> None:
        self._read_geometry()

    def _read_geometry(self) -> None:
        self.geometry = (_read_only(self.layout.positions), _read_only(self.layout.normals),
                         None if self.layout.weights is None
                         else _read_only(self.layout.weights))

    @classmethod
    def for_layout(cls, board_id: int, layout: SkinLayout, config: CalibrationConfig,
                   publisher: Publisher) -> _Channel:
        """The channel of ``board_id``: its layout's calibrator and encoder."""
        return cls(board_id, layout, _calibrator(layout, config), _encoder(layout), publisher)

    def set_layout(self, layout: SkinLayout, config: CalibrationConfig) -> None:
        """Take a reloaded layout: its geometry, a new calibrator (which tares again) and
        encoder; the counters and the publisher stay."""
        self.layout = layout
        self.calibrator = _calibrator(layout, config)
        self.encoder = _encoder(layout)
        self.mismatch_logged = False
        self._read_geometry()


def _calibrator(layout: SkinLayout, config: CalibrationConfig) -> PatchCalibrator:
    return PatchCalibrator(layout.size, config, layout.gains, layout.offsets, layout.dead)


def _encoder(layout: SkinLayout) -> TaxelCloudEncoder:
    return TaxelCloudEncoder(layout.positions, layout.normals, layout.link, layout.weights)


def _read_only(array: FloatArray) -> FloatArray:
    """A read-only copy of ``array``."""
    copy = np.array(array, dtype=np.float64)
    copy.flags.writeable = False
    return copy


class SkinDriverNode(Node):
    """Skin driver for one serial port (see module docstring)."""

    _listeners: list[FrameListener]
    """Called with every calibrated frame (add_frame_listener)."""

    def __init__(
        self,
        *,
        context: Context | None = None,
        node_name: str = "skin_driver",
        parameter_overrides: list[Parameter] | None = None,
        poller: PortPoller | None = None,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        """``poller``: read the port on this shared thread (several drivers in one process,
        ``skin_contact_node``) instead of the node's own serial thread. ``clock``: the monotonic
        clock [s] of the silence and unframed-bytes timeouts, the publication rate limit,
        calibration (drift, stuck taxels) and diagnostics (tests replace it)."""
        super().__init__(node_name, context=context, parameter_overrides=parameter_overrides)
        self._poller, self._mono = poller, clock
        try:
            self._values = declare_parameters(self, PARAMS, on_change=self._on_change)
            v = self._values
            config = calibration_config(v)
            layouts = load_patches(
                [int(b) for b in v["board_ids"]],
                [str(f) for f in v["layout_files"]],
            )
        except ParameterValueError:
            # Refused configuration: leave nothing registered with the context.
            super().destroy_node()
            raise
        self._lock = threading.Lock()
        self._config = config
        self._channels = self._make_channels(layouts, config, int(v["qos_depth"]))
        self._listeners, self._publish_period = [], _period_s(float(v["taxel_publish_rate_hz"]))
        self._url = str(v["port"])
        self._parser = FrameParser(int(v["max_taxels"]))
        self._unknown_board_frames = 0
        self._errors_at_last_diag = 0
        self._last_diag_mono = self._mono()
        self._port_warned = False
        self._unframed_since: float | None = None  # first read without an intact frame since one
        self._unframed_bytes = 0
        self._unframed_warned = False
        self._diag_pub = self.create_publisher(DiagnosticArray, "/diagnostics", 10)
        self._tare_srv = self.create_service(Trigger, "~/tare", self._on_tare)
        self._reload_srv = self.create_service(Trigger, "~/reload_layouts", self._on_reload)
        self.create_timer(float(v["diagnostics_period"]), self.publish_diagnostics)
        silence = float(v["silence_timeout"])
        self._silence_timer = self.create_timer(max(silence / 2.0, 0.002), self._check_silence)
        self._reader = self._make_reader(v)
        self._reader.start()
        patches = ", ".join(f"{b}→{c.layout.patch}" for b, c in self._channels.items())
        self.get_logger().info(f"reading {self._url}; boards {patches}")

    def _make_channels(self, layouts: dict[int, SkinLayout], config: CalibrationConfig,
                       qos_depth: int) -> dict[int, _Channel]:
        """One channel (:meth:`_Channel.for_layout`, with a reliable publisher of
        ``qos_depth``) per board."""
        qos = QoSProfile(
            history=HistoryPolicy.KEEP_LAST,
            depth=qos_depth,
            reliability=ReliabilityPolicy.RELIABLE,
        )
        return {
            board: _Channel.for_layout(board, layout, config, self.create_publisher(
                PointCloud2, f"skin/{layout.patch}/taxels", qos))
            for board, layout in layouts.items()
        }

    @property
    def patches(self) -> tuple[str, ...]:
        """The patch names of this port's boards (from their layouts)."""
        return tuple(c.layout.patch for c in self._channels.values())

    def add_frame_listener(self, listener: FrameListener) -> None:
        """Call ``listener(patch, taxels)`` with every calibrated frame, on the serial thread,
        before (and whatever the rate of) its publication: a contact estimator composed into
        this process takes frames this way (``phri_bringup.skin_contact_node``)."""
        with self._lock:
            self._listeners.append(listener)

    def _make_reader(self, v: dict[str, ParamValue]) -> SerialReader:
        return SerialReader(
            self._url,
            self._on_data,
            baudrate=int(v["baudrate"]),
            backoff_initial=float(v["reconnect_backoff_initial"]),
            backoff_max=max(
                float(v["reconnect_backoff_max"]),
                float(v["reconnect_backoff_initial"]),
            ),
            clock=lambda: self.get_clock().now().nanoseconds,
            on_connect=self._on_connect,
            on_error=self._on_port_error,
            poller=self._poller,
            priority=int(v["thread_priority"]),
            on_priority_refused=lambda message: self.get_logger().warning(message),
        )

    # ------------------------------------------------------------------ serial thread side

    def _on_connect(self) -> None:
        with self._lock:
            # A new connection is a new stream: a half frame from before is garbage.
            self._parser.reset()
        self._port_warned = False
        self.get_logger().info(f"port {self._url} open")

    def _on_port_error(self, message: str) -> None:
        # Once per outage: the back-off retries would otherwise flood the log.
        if not self._port_warned:
            self._port_warned = True
            self.get_logger().error(f"{message}; retrying with back-off")

    def _on_data(self, chunk: bytes, arrival_ns: int) -> None:
        with self._lock:
            frames = self._parser.feed(chunk)
            mono = self._mono()
            if frames:
                self._unframed_since, self._unframed_bytes = None, 0
            else:
                if self._unframed_since is None:
                    self._unframed_since = mono
                self._unframed_bytes += len(chunk)
            for frame in frames:
                self._on_frame(frame, arrival_ns, mono)

    def _on_frame(self, frame: Frame, arrival_ns: int, mono: float) -> None:
        channel = self._channels.get(frame.board_id)
        if channel is None:
            self._unknown_board_frames += 1
            return
        if frame.counts.shape[0] != channel.layout.size:
            self._refuse_size(channel, frame.counts.shape[0])
            return
        channel.sequence.observe(frame.sequence)
        stamp_ns = channel.clock.stamp(frame.board_time_us, arrival_ns)
        channel.frames += 1
        channel.last_frame_mono = mono
        if channel.silent:
            channel.silent = False
            channel.calibrator.reset_filter()
            self.get_logger().info(f"board {frame.board_id} ({channel.layout.patch}) is sending")
        forces = channel.calibrator.process(frame.counts, mono)
        if forces is None:
            return
        if self._listeners:
            forces.flags.writeable = False  # a fresh array per frame, now shared read-only
            positions, normals, weights = channel.geometry
            taxels = TaxelArray(positions, normals, forces, weights, channel.layout.link,
                                stamp_ns)
            for listener in self._listeners:
                listener(channel.layout.patch, taxels)
        if mono >= channel.next_publish_mono:
            channel.publisher.publish(channel.encoder.encode(forces, stamp_ns))
            channel.published += 1
            if self._publish_period > 0.0:
                channel.next_publish_mono = mono + self._publish_period - 1e-6

    def _refuse_size(self, channel: _Channel, taxels: int) -> None:
        """Count a frame of ``taxels`` taxels on a board whose layout has another count: it is
        not published (a geometry changes only by ``~/reload_layouts``). Logged once per
        layout (the diagnostics carry the count and both sizes)."""
        channel.size_mismatches += 1
        channel.wrong_size = taxels
        if not channel.mismatch_logged:
            channel.mismatch_logged = True
            self.get_logger().warning(
                f"board {channel.board_id} ({channel.layout.patch}): refused a frame of "
                f"{taxels} taxels, the layout has {channel.layout.size} (not published; to "
                "change the geometry, update the layout file and call ~/reload_layouts)"
            )

    # ----------------------------------------------------------------------- executor side

    def _on_change(self, values: dict[str, ParamValue]) -> None:
        """Run-time parameter change (only ``silence_timeout`` is writable): re-arm its timer."""
        silence = float(values["silence_timeout"])
        self._silence_timer.timer_period_ns = int(max(silence / 2.0, 0.002) * 1e9)

    def _unframed_for(self, now: float) -> float:
        """How long bytes have been arriving without an intact frame [s] (0 if not)."""
        since = self._unframed_since
        return 0.0 if since is None else now - since

    def _check_silence(self) -> None:
        timeout = float(self._values["silence_timeout"])
        now = self._mono()
        unframed = self._unframed_for(now) > timeout
        if unframed and not self._unframed_warned:
            self.get_logger().warning(
                f"port {self._url}: {self._unframed_bytes} bytes in "
                f"{self._unframed_for(now):.2f} s without an intact frame (wrong device, "
                "baud rate or protocol version?)"
            )
            self.publish_diagnostics()
        self._unframed_warned = unframed
        newly_silent = []
        with self._lock:
            for channel in self._channels.values():
                if not channel.silent and now - channel.last_frame_mono > timeout:
                    channel.silent = True
                    newly_silent.append(channel)
        for channel in newly_silent:
            self.get_logger().warning(
                f"board {channel.board_id} ({channel.layout.patch}) silent for more than "
                f"{timeout:g} s: stopped publishing skin/{channel.layout.patch}/taxels"
            )
        if newly_silent:
            self.publish_diagnostics()

    def _on_tare(self, request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        with self._lock:
            for channel in self._channels.values():
                channel.calibrator.tare()
        response.success = True
        response.message = f"taring {len(self._channels)} patch(es)"
        return response

    def _on_reload(self, request: Trigger.Request,
                   response: Trigger.Response) -> Trigger.Response:
        """``~/reload_layouts``: read every layout file again; a board whose layout changed
        takes the new geometry and calibration (and tares again). All or nothing: a file that
        does not load, or that renames a board's patch or link, changes nothing."""
        v = self._values
        try:
            with self._lock:
                current = {b: c.layout for b, c in self._channels.items()}
            layouts = reload_patches(current, [int(b) for b in v["board_ids"]],
                                     [str(f) for f in v["layout_files"]])
        except ParameterValueError as err:
            response.success, response.message = False, str(err)
            self.get_logger().error(f"~/reload_layouts refused: {err}")
            return response
        changed = []
        with self._lock:
            for board, layout in layouts.items():
                channel = self._channels[board]
                if not same_layout(layout, channel.layout):
                    changed.append(f"{layout.patch}: {channel.layout.size} → {layout.size} "
                                   "taxels, taring")
                    channel.set_layout(layout, self._config)
        response.success = True
        response.message = "reloaded: " + ("; ".join(changed) if changed else "no change")
        self.get_logger().info(f"~/reload_layouts {response.message}")
        return response

    def snapshot(self) -> tuple[PortSnapshot, list[BoardSnapshot]]:
        """Current state of the port and every board (for diagnostics and tests)."""
        now = self._mono()
        with self._lock:
            elapsed = max(now - self._last_diag_mono, 1e-6)
            self._last_diag_mono = now
            s = self._parser.stats
            errors = s.errors + s.resyncs
            t = self._reader.stats
            port = PortSnapshot(
                url=self._url,
                connected=t.connected,
                connects=t.connects,
                disconnects=t.disconnects,
                failed_opens=t.failed_opens,
                bytes_read=t.bytes_read,
                crc_errors=s.crc_errors,
                bad_headers=s.bad_headers,
                false_lengths=s.false_lengths,
                resyncs=s.resyncs,
                discarded_bytes=s.discarded_bytes,
                unknown_board_frames=self._unknown_board_frames,
                new_errors=errors - self._errors_at_last_diag,
                last_error=t.last_error,
                unframed_s=self._unframed_for(now),
                unframed_bytes=self._unframed_bytes,
                unframed_limit_s=float(self._values["silence_timeout"]),
            )
            self._errors_at_last_diag = errors
            boards = []
            for board, c in self._channels.items():
                dropped = c.sequence.dropped
                boards.append(
                    BoardSnapshot(
                        board_id=board,
                        patch=c.layout.patch,
                        link=c.layout.link,
                        taxels=c.layout.size,
                        rate_hz=(c.frames - c.frames_at_last_diag) / elapsed,
                        frames=c.frames,
                        published=c.published,
                        dropped=dropped,
                        new_drops=dropped - c.dropped_at_last_diag,
                        restarts=c.sequence.restarts,
                        size_mismatches=c.size_mismatches,
                        new_size_mismatches=c.size_mismatches - c.mismatches_at_last_diag,
                        wrong_size_taxels=c.wrong_size,
                        clock_restarts=c.clock.restarts,
                        silent=c.silent,
                        last_frame_age_s=(now - c.last_frame_mono) if c.frames else float("inf"),
                        calibration=c.calibrator.status(),
                    )
                )
                c.frames_at_last_diag = c.frames
                c.dropped_at_last_diag = dropped
                c.mismatches_at_last_diag = c.size_mismatches
        return port, boards

    def publish_diagnostics(self) -> None:
        port, boards = self.snapshot()
        msg = DiagnosticArray()
        msg.header.stamp = ns_to_stamp(self.get_clock().now().nanoseconds)
        msg.status = [port_status(port), *(board_status(b, self._url) for b in boards)]
        self._diag_pub.publish(msg)

    def destroy_node(self) -> None:
        reader = getattr(self, "_reader", None)  # absent if the constructor failed early
        if reader is not None:
            reader.stop()
        super().destroy_node()


def main(args: Sequence[str] | None = None) -> int:
    """Console entry point ``skin_driver_node [--ros-args …]``: run until SIGINT/SIGTERM.

    The serial thread does the per-frame work; the executor only runs timers and services.
    ``phri_common.ros_main.run_nodes`` drives it (``PHRI_EXECUTOR``: ``events`` by default, or
    ``single``; never ``EventsExecutor.spin()``, which busy-loops and ignores signals). A refused
    parameter exits with code 2 and a message naming it.
    """
    return run_nodes(lambda: [SkinDriverNode()], "skin_driver", args)


if __name__ == "__main__":
    sys.exit(main())
