"""The driver node end to end: simulated board on a pty → node → subscriber."""

from __future__ import annotations

import binascii
import struct
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from sensor_msgs.msg import PointCloud2

from phri_common.params import ParameterValueError
from phri_common.records import TaxelArray
from phri_common.taxels import msg_to_taxels
from phri_common.testing import spin_until
from skin_driver.layout import rectangular_patch, save_layout
from skin_driver.node import SkinDriverNode
from skin_driver.protocol import encode_frame
from skin_driver.sim_board import Faults, PtyEndpoint, SimBoard, press_pattern, run_boards

RATE = 500.0


class Board:
    """A simulated board on a pty behind a stable symlink; can vanish and come back."""

    def __init__(self, link: Path, boards: list, faults: Faults | None = None) -> None:
        self.link, self.boards = link, boards
        self.stop = threading.Event()
        self.thread: threading.Thread | None = None

    def start(self) -> None:
        self.stop = threading.Event()
        self.thread = threading.Thread(
            target=run_boards,
            args=(lambda: PtyEndpoint(self.link), self.boards, RATE, self.stop),
            daemon=True,
        )
        self.thread.start()
        deadline = time.monotonic() + 5
        while not self.link.exists() and time.monotonic() < deadline:
            time.sleep(0.01)

    def vanish(self) -> None:
        self.stop.set()
        if self.thread is not None:
            self.thread.join(5)


class Listener:
    def __init__(self, node: Node, topic: str) -> None:
        self.times: list[float] = []
        self.msgs: list[PointCloud2] = []
        self.diags: list[DiagnosticArray] = []
        node.create_subscription(PointCloud2, topic, self._on, 50)
        node.create_subscription(DiagnosticArray, "/diagnostics", self.diags.append, 50)

    def _on(self, msg: PointCloud2) -> None:
        self.times.append(time.monotonic())
        self.msgs.append(msg)


def _status(listener: Listener, name_part: str) -> DiagnosticStatus | None:
    for arr in reversed(listener.diags):
        for s in arr.status:
            if name_part in s.name:
                return s
    return None


def _value(status: DiagnosticStatus, key: str) -> str:
    return next(kv.value for kv in status.values if kv.key == key)


@pytest.fixture
def setup(tmp_path: Path):  # type: ignore[no-untyped-def]
    layout = rectangular_patch("forearm", "forearm_link", 6, 6)
    path = tmp_path / "forearm.yaml"
    save_layout(layout, path)
    return layout, path, tmp_path / "skin_port"


def _node(ros_context, port: Path, layout_file: Path, **extra) -> SkinDriverNode:  # type: ignore[no-untyped-def]
    overrides = [
        Parameter("port", value=str(port)),
        Parameter("board_ids", value=[4]),
        Parameter("layout_files", value=[str(layout_file)]),
        Parameter("reconnect_backoff_initial", value=0.05),
        Parameter("reconnect_backoff_max", value=0.2),
        Parameter("diagnostics_period", value=0.2),
        *(Parameter(k, value=v) for k, v in extra.items()),
    ]
    return SkinDriverNode(context=ros_context, parameter_overrides=overrides)



def _listen(ros_context, node):  # type: ignore[no-untyped-def]
    """A listener node on the forearm patch's taxels and an executor spinning both nodes."""
    sub = Node("listener", context=ros_context)
    listener = Listener(sub, "skin/forearm/taxels")
    ex = SingleThreadedExecutor(context=ros_context)
    ex.add_node(node)
    ex.add_node(sub)
    return sub, listener, ex

@pytest.mark.ros
def test_pty_board_to_subscriber_and_recovery(ros_context, setup) -> None:  # type: ignore[no-untyped-def]
    layout, layout_file, link = setup
    pressed = press_pattern(layout, force=4.0, radius=0.008, period=0.0)  # held press
    board = Board(link, [(SimBoard(4, layout, noise_counts=2.0, seed=0), pressed)])
    board.start()
    node = _node(ros_context, link, layout_file)
    sub, listener, ex = _listen(ros_context, node)
    try:
        # Tare (0.2 s) then steady publishing.
        assert spin_until(ex, lambda: len(listener.msgs) >= 50, timeout_s=15.0)
        n0, t0 = len(listener.msgs), time.monotonic()
        spin_until(ex, lambda: time.monotonic() - t0 > 2.0, timeout_s=3.0)
        rate = (len(listener.msgs) - n0) / (time.monotonic() - t0)
        assert rate >= 0.6 * RATE, f"received {rate:.0f} Hz"
        taxels = msg_to_taxels(listener.msgs[-1])
        assert taxels.frame_id == "forearm_link"
        np.testing.assert_allclose(taxels.positions, layout.positions, atol=1e-6)
        # The press was held through tare, with 4 N spread over the taxels in 8 mm: it is
        # above tare_max_shift per taxel, so it stays visible at its true force.
        expected = pressed(0.0)
        np.testing.assert_allclose(taxels.forces, expected, atol=0.01)
        assert taxels.forces.sum() == pytest.approx(4.0, abs=0.05)
        stamp_age = time.time_ns() - taxels.stamp_ns
        assert 0 <= stamp_age < 5e9

        # The board disappears: publishing stops, diagnostics say so.
        board.vanish()
        assert spin_until(
            ex,
            lambda: (s := _status(listener, "forearm")) is not None
            and s.level == DiagnosticStatus.ERROR and "silent" in s.message,
            timeout_s=5.0,
        )
        port = _status(listener, "port")
        assert port is not None
        spin_until(ex, lambda: False, timeout_s=0.3)
        n_silent = len(listener.msgs)
        spin_until(ex, lambda: False, timeout_s=0.5)
        assert len(listener.msgs) == n_silent  # nothing published while silent

        # It comes back (new pty behind the same link): the node reconnects and publishes.
        board.start()
        assert spin_until(ex, lambda: len(listener.msgs) >= n_silent + 100, timeout_s=15.0)
        assert node._reader.stats.connects >= 2
        assert spin_until(
            ex,
            lambda: (s := _status(listener, "forearm")) is not None
            and s.level != DiagnosticStatus.ERROR,
            timeout_s=5.0,
        )
        np.testing.assert_allclose(msg_to_taxels(listener.msgs[-1]).forces, expected, atol=0.01)
    finally:
        board.vanish()
        node.destroy_node()
        sub.destroy_node()


@pytest.mark.ros
def test_corrupted_line_is_counted_and_survived(ros_context, setup) -> None:  # type: ignore[no-untyped-def]
    layout, layout_file, link = setup
    faults = Faults(garbage_rate=0.2, bitflip_rate=0.05, drop_rate=0.05)
    pattern = press_pattern(layout, force=2.0, radius=0.01, period=0.4)
    board = Board(link, [(SimBoard(4, layout, faults=faults, seed=1), pattern),
                         (SimBoard(9, layout, seed=2), pattern)])  # 9: not configured
    board.start()
    node = _node(ros_context, link, layout_file)
    sub, listener, ex = _listen(ros_context, node)
    try:
        assert spin_until(ex, lambda: len(listener.msgs) >= 300, timeout_s=15.0)
        port, boards = node.snapshot()
        assert port.crc_errors > 0 and port.resyncs > 0 and port.unknown_board_frames > 0
        assert boards[0].dropped > 0
        for msg in listener.msgs[-50:]:
            f = msg_to_taxels(msg).forces
            assert np.all(np.isfinite(f)) and np.all(f >= 0) and f.sum() < 2.1
    finally:
        board.vanish()
        node.destroy_node()
        sub.destroy_node()


@pytest.mark.ros
def test_bad_parameters_are_refused(ros_context, setup, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    _, layout_file, link = setup
    with pytest.raises(ParameterValueError, match="layout_files"):
        SkinDriverNode(context=ros_context, parameter_overrides=[
            Parameter("port", value=str(link)), Parameter("board_ids", value=[1, 2]),
            Parameter("layout_files", value=[str(layout_file)])])
    with pytest.raises(ParameterValueError, match="filter_window"):
        _node(ros_context, link, layout_file, filter_window=0)
    missing = tmp_path / "nope.yaml"
    with pytest.raises(ParameterValueError, match=r"nope\.yaml"):
        _node(ros_context, link, missing)
    # No board behind the port: the node starts, retries, and refuses a bad run-time value.
    node = _node(ros_context, link, layout_file)
    try:
        result = node.set_parameters([Parameter("silence_timeout", value=float("nan"))])[0]
        assert not result.successful and "silence_timeout" in result.reason
        assert node.set_parameters([Parameter("silence_timeout", value=0.5)])[0].successful
        assert node._silence_timer.timer_period_ns == 250_000_000  # the check follows it
        port, boards = node.snapshot()
        assert not port.connected and boards[0].silent
    finally:
        node.destroy_node()


@pytest.mark.ros
def test_two_patches_on_one_port(ros_context, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    a = rectangular_patch("upper", "upper_link", 4, 4)
    b = rectangular_patch("lower", "lower_link", 3, 5)
    save_layout(a, tmp_path / "a.yaml")
    save_layout(b, tmp_path / "b.yaml")
    link = tmp_path / "port"
    pa = press_pattern(a, force=3.0, radius=0.005, period=0.0)
    pb = press_pattern(b, force=1.5, radius=0.005, period=0.0)  # > tare_max_shift
    board = Board(link, [(SimBoard(7, b, seed=1), pb), (SimBoard(2, a, seed=2), pa)])
    board.start()
    node = SkinDriverNode(context=ros_context, parameter_overrides=[
        Parameter("port", value=str(link)), Parameter("board_ids", value=[2, 7]),
        Parameter("layout_files", value=[str(tmp_path / "a.yaml"), str(tmp_path / "b.yaml")])])
    sub = Node("listener", context=ros_context)
    la, lb = Listener(sub, "skin/upper/taxels"), Listener(sub, "skin/lower/taxels")
    ex = SingleThreadedExecutor(context=ros_context)
    ex.add_node(node)
    ex.add_node(sub)
    try:
        assert spin_until(ex, lambda: len(la.msgs) > 50 and len(lb.msgs) > 50, timeout_s=15.0)
        ta, tb = msg_to_taxels(la.msgs[-1]), msg_to_taxels(lb.msgs[-1])
        assert (ta.frame_id, ta.size, tb.frame_id, tb.size) == ("upper_link", 16, "lower_link", 15)
        np.testing.assert_allclose(ta.forces, pa(0.0), atol=0.01)
        np.testing.assert_allclose(tb.forces, pb(0.0), atol=0.01)
    finally:
        board.vanish()
        node.destroy_node()
        sub.destroy_node()


class ForgingBoard(SimBoard):
    """A board whose stream carries forged data after some frames (valid CRCs, wrong sizes).

    After frame ``forge_at``: a header announcing 16,384 taxels (32 KB: ≈ 350 of this board's
    frames). Every 50th frame: a complete frame of 10 taxels (this board has 36) with a random
    sequence number.
    """

    forge_at = 300

    def frame(self, forces, t, *, overrun=False):  # type: ignore[no-untyped-def, override]
        data = super().frame(forces, t, overrun=overrun)
        seq = (self.sequence - 1) % 65536
        if seq == self.forge_at:
            head = struct.pack("<2sBBBBHHI", b"\xa5\x5a", 1, 1, self.board_id, 0, 7, 16384, 0)
            data += head + struct.pack("<H", binascii.crc_hqx(head, 0xFFFF))
        if seq % 50 == 25:
            rogue = int(self._rng.integers(0, 65536))
            data += encode_frame(self.board_id, rogue, np.full(10, 1000), board_time_us=rogue)
        return data


@pytest.mark.ros
def test_forged_header_costs_no_stall_and_every_frame_keeps_its_own_stamp(  # type: ignore[no-untyped-def]
    ros_context, setup
) -> None:
    layout, layout_file, link = setup
    board = Board(link, [(ForgingBoard(4, layout, noise_counts=0.0, seed=3),
                          press_pattern(layout, force=2.0, radius=0.01, period=0.0))])
    board.start()
    node = _node(ros_context, link, layout_file, tare_frames=20, qos_depth=100)
    sub, listener, ex = _listen(ros_context, node)
    try:
        # Publishing starts at frame 20; the forged header follows frame 300 (t = 0.6 s).
        assert spin_until(ex, lambda: len(listener.msgs) >= 600, timeout_s=30.0)
        port, boards = node.snapshot()
    finally:
        board.vanish()
        node.destroy_node()
        sub.destroy_node()
    assert port.false_lengths >= 1  # the forged length was abandoned, not waited for
    stamps = np.array([msg_to_taxels(m).stamp_ns for m in listener.msgs])
    steps = np.diff(stamps) / 2e6  # in board periods (2 ms)
    # Every frame has its own stamp, spaced by the board's clock: whole periods (a frame lost
    # under load is a gap of 2 or more), never a shared arrival time (a step of ≈ 0). The offset
    # estimate (smallest arrival − board time) settles a few 0.1 ms in the first frames and may
    # step down once more when a busy machine first delivers a frame faster: ≤ 1 % of steps.
    assert np.all(steps > 0.5)
    off_grid = np.abs(steps[50:] - np.round(steps[50:])) > 0.2
    assert np.count_nonzero(off_grid) <= max(1, len(off_grid) // 100), steps[50:][off_grid]
    gaps = int(np.sum(np.round(steps) - 1))
    # No stall: the forged length was dropped by the look-ahead (false_lengths above), never
    # waited out (32 KB, ≈ 0.7 s of frames held back, then a frame CRC error). That each frame
    # is returned by the read that completes it is test_protocol's (no wall clock here: a
    # loaded machine's pauses are not the parser's).
    assert port.crc_errors == 0
    # dropped counts sequence gaps of this board's accepted frames only: the rogue frames
    # (random sequence numbers, wrong size) are size mismatches, not drops.
    assert boards[0].size_mismatches >= 5
    assert boards[0].dropped <= gaps + 5 and boards[0].restarts == 0


@pytest.mark.ros
def test_bytes_without_a_valid_frame_turn_the_port_warn(ros_context, setup) -> None:  # type: ignore[no-untyped-def]
    _, layout_file, link = setup
    endpoint = PtyEndpoint(link)
    node = _node(ros_context, link, layout_file, silence_timeout=0.2)
    sub, listener, ex = _listen(ros_context, node)
    rng = np.random.default_rng(5)
    try:
        assert spin_until(ex, lambda: node._reader.stats.connected, timeout_s=10.0)
        end = time.monotonic() + 1.5
        while time.monotonic() < end:  # bytes that never contain a sync word
            endpoint.write(rng.integers(0, 0xA5, 200).astype(np.uint8).tobytes())
            spin_until(ex, lambda: False, timeout_s=0.01)
        assert spin_until(
            ex,
            lambda: (s := _status(listener, "port")) is not None
            and s.level == DiagnosticStatus.WARN and "without an intact frame" in s.message,
            timeout_s=3.0,
        )
        port, _ = node.snapshot()
        assert port.connected and port.unframed_bytes > 10_000
    finally:
        endpoint.close()
        node.destroy_node()
        sub.destroy_node()


def test_duplicate_board_ids_are_refused_naming_value_and_rule(tmp_path: Path) -> None:
    from skin_driver.node import load_patches

    with pytest.raises(ParameterValueError, match=r"'board_ids' refused value \[3, 3\]: .*unique"):
        load_patches([3, 3], [str(tmp_path / "a.yaml"), str(tmp_path / "b.yaml")])


def test_node_process_refuses_a_bad_parameter_with_exit_code_2(tmp_path: Path) -> None:
    """The console entry point (phri_common.ros_main.run_nodes) names the refused parameter."""
    exe = Path(sys.executable).with_name("skin_driver_node")
    result = subprocess.run([str(exe), "--ros-args", "-p", "filter_window:=0"], cwd=tmp_path,
                            capture_output=True, text=True, timeout=60, check=False)
    assert result.returncode == 2
    assert "parameter 'filter_window'" in result.stderr and "refused value 0" in result.stderr


@pytest.mark.ros
def test_frame_listeners_get_shared_read_only_arrays(ros_context, setup) -> None:  # type: ignore[no-untyped-def]
    """A composed estimator's hand-off copies nothing per frame: every TaxelArray shares one
    read-only copy of the layout's geometry, and its forces are read-only (a listener cannot
    change what the publisher then sends)."""
    layout, layout_file, link = setup
    pressed = press_pattern(layout, force=4.0, radius=0.008, period=0.0)
    board = Board(link, [(SimBoard(4, layout, noise_counts=2.0, seed=0), pressed)])
    board.start()
    node = _node(ros_context, link, layout_file, tare_frames=5)
    got: list[TaxelArray] = []
    node.add_frame_listener(lambda patch, taxels: got.append(taxels))
    try:
        deadline = time.monotonic() + 10.0
        while len(got) < 20 and time.monotonic() < deadline:
            time.sleep(0.01)
        assert len(got) >= 20
        first, last = got[0], got[-1]
        assert last.positions is first.positions and last.normals is first.normals
        assert not last.positions.flags.writeable and not last.forces.flags.writeable
        assert last.forces is not first.forces
        np.testing.assert_array_equal(last.positions, layout.positions)
        np.testing.assert_allclose(last.forces, pressed(0.0), atol=0.01)
    finally:
        board.vanish()
        node.destroy_node()


# --- a frame of another size is refused; a geometry changes only by ~/reload_layouts ---------


def _quiet_node(ros_context, tmp_path: Path, layout_file: Path) -> SkinDriverNode:  # type: ignore[no-untyped-def]
    """A node whose port never opens: the test hands it bytes itself (``_on_data``)."""
    return _node(ros_context, tmp_path / "no_such_port", layout_file, tare_frames=0)


def _frames_of(node: SkinDriverNode) -> list[TaxelArray]:
    got: list[TaxelArray] = []
    node.add_frame_listener(lambda patch, taxels: got.append(taxels))
    return got


@pytest.mark.ros
def test_a_frame_of_another_size_is_refused_counted_reported_and_the_next_one_used(  # type: ignore[no-untyped-def]
    ros_context, setup, tmp_path
) -> None:
    from skin_driver.diagnostics import board_status

    layout, layout_file, _ = setup
    node = _quiet_node(ros_context, tmp_path, layout_file)
    got = _frames_of(node)
    try:
        node._on_data(encode_frame(4, 0, np.full(36, 1000)), 0)
        node._on_data(encode_frame(4, 1, np.full(40, 1000)), 2_000_000)  # 40 ≠ the layout's 36
        assert len(got) == 1
        node._on_data(encode_frame(4, 2, np.full(36, 1000)), 4_000_000)
        port, (board,) = node.snapshot()
    finally:
        node.destroy_node()
    assert [t.size for t in got] == [36, 36]  # the geometry stayed the layout's
    np.testing.assert_array_equal(got[-1].positions, layout.positions)
    assert (board.size_mismatches, board.wrong_size_taxels, board.taxels) == (1, 40, 36)
    assert board.frames == 2 and board.dropped == 1  # sequence 1 was not accepted
    status = board_status(board, port.url)
    assert status.level == DiagnosticStatus.WARN
    assert "forearm" in status.name and "board 4" in status.name
    assert "1 frames of the wrong size refused (40 taxels, the layout has 36)" in status.message
    assert _value(status, "wrong_size_taxels") == "40"


@pytest.mark.ros
def test_reload_layouts_announces_a_new_geometry(ros_context, setup, tmp_path) -> None:  # type: ignore[no-untyped-def]
    from std_srvs.srv import Trigger

    _, layout_file, _ = setup
    node = _quiet_node(ros_context, tmp_path, layout_file)
    got = _frames_of(node)
    bigger = rectangular_patch("forearm", "forearm_link", 6, 7)
    try:
        save_layout(bigger, layout_file)  # a new file alone changes nothing
        node._on_data(encode_frame(4, 0, np.full(42, 1000)), 0)
        assert got == [] and node.snapshot()[1][0].size_mismatches == 1
        answer = node._on_reload(Trigger.Request(), Trigger.Response())
        assert answer.success and "forearm: 36 → 42 taxels" in answer.message
        node._on_data(encode_frame(4, 1, np.full(42, 1000)), 2_000_000)
        node._on_data(encode_frame(4, 2, np.full(36, 1000)), 4_000_000)  # the old size: refused
        assert [t.size for t in got] == [42]
        np.testing.assert_array_equal(got[0].positions, bigger.positions)
        # All or nothing: a file renaming the patch, or one that does not load, changes nothing.
        save_layout(rectangular_patch("elsewhere", "forearm_link", 6, 6), layout_file)
        refused = node._on_reload(Trigger.Request(), Trigger.Response())
        assert not refused.success and "board 4 is patch 'forearm'" in refused.message
        layout_file.write_text("not a layout")
        assert not node._on_reload(Trigger.Request(), Trigger.Response()).success
        node._on_data(encode_frame(4, 3, np.full(42, 1000)), 6_000_000)
        assert [t.size for t in got] == [42, 42]
        assert node.snapshot()[1][0].size_mismatches == 2
    finally:
        node.destroy_node()
