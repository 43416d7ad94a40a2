"""skin_contact_node: skin driver and contact estimation composed, frames handed over directly."""

from __future__ import annotations

import threading
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from sensor_msgs.msg import PointCloud2

from phri_bringup.skin_contact_node import compose
from phri_common.contact import msg_to_contact
from phri_common.testing import spin_until
from skin_driver.layout import rectangular_patch, save_layout
from skin_driver.sim_board import PtyEndpoint, SimBoard, press_pattern, run_boards

RATE = 500.0
WAIT_S = 60.0
"""Longest wait for something that must happen (a stalled machine); never a measured time."""


def driver_params(port: Path, layout_file: Path, publish_hz: float) -> list[Parameter]:
    return [Parameter("port", value=str(port)), Parameter("board_ids", value=[4]),
            Parameter("layout_files", value=[str(layout_file)]),
            Parameter("taxel_publish_rate_hz", value=publish_hz)]


ESTIMATOR = [Parameter("patches", value=["forearm"]),
             Parameter("patch_links", value=["forearm_link"])]


@pytest.mark.ros
def test_every_frame_reaches_the_estimator_while_the_taxel_topic_is_throttled(
    ros_context: Any, tmp_path: Path
) -> None:
    """Every frame the driver calibrates reaches the composed estimator directly, before the
    next one (a listener after the estimator's sees the estimator's count equal its own), while
    the taxel topic is published at the driver's taxel_publish_rate_hz (that rate limit on a
    fake clock: skin_driver's test_node; the rates on a real machine: bench_chain)."""
    layout = rectangular_patch("forearm", "forearm_link", 6, 6)
    save_layout(layout, tmp_path / "forearm.yaml")
    port = tmp_path / "port"
    press = press_pattern(layout, force=4.0, radius=0.008, period=0.0)
    stop = threading.Event()
    board = threading.Thread(target=run_boards, daemon=True, args=(
        lambda: PtyEndpoint(port), [(SimBoard(4, layout, seed=0), press)], RATE, stop))
    board.start()
    deadline = time.monotonic() + WAIT_S
    while not port.exists() and time.monotonic() < deadline:
        time.sleep(0.01)
    nodes = compose(["driver"], context=ros_context, overrides={
        "driver": driver_params(port, tmp_path / "forearm.yaml", 50.0),
        "contact_estimation": ESTIMATOR})
    estimation, driver = nodes
    seen: list[tuple[int, int]] = []  # (frames this listener had, frames the estimator had)

    def after_the_estimator(_patch: str, _taxels: Any) -> None:
        seen.append((len(seen) + 1, estimation.received_frames["forearm"]))

    driver.add_frame_listener(after_the_estimator)  # type: ignore[attr-defined]
    peer = Node("peer", context=ros_context)
    states: list[PointCloud2] = []
    taxels: list[PointCloud2] = []
    peer.create_subscription(PointCloud2, "contacts/forearm_link", states.append, 100)
    peer.create_subscription(PointCloud2, "skin/forearm/taxels", taxels.append, 100)
    executor = SingleThreadedExecutor(context=ros_context)
    for node in [*nodes, peer]:
        executor.add_node(node)
    try:
        assert spin_until(executor, lambda: len(states) >= 200 and bool(taxels),
                          timeout_s=WAIT_S)
        frames = list(seen)
        assert len(frames) >= 200
        # Each frame reached the estimator just before this listener: its count rose by one
        # per frame (offset: frames it had before this listener was added; none on a quiet
        # machine, where the 100 tare frames outlast that).
        offset = frames[0][1] - frames[0][0]
        assert offset >= 0 and all(theirs - mine == offset for mine, theirs in frames)
        assert estimation.refused_frames["forearm"] == 0
        state = msg_to_contact(states[-1])
        assert state.in_contact and state.link == "forearm_link"
        assert float(np.linalg.norm(state.force)) == pytest.approx(4.0, abs=0.05)
        assert driver.get_parameter("taxel_publish_rate_hz").value == 50.0
        # The estimator does not also take the (throttled) topic: only the peer listens.
        assert nodes[1].count_subscribers("skin/forearm/taxels") == 1
    finally:
        stop.set()
        board.join(WAIT_S)
        for node in [peer, *nodes]:
            node.destroy_node()


def test_a_driver_patch_unknown_to_the_estimator_is_refused_by_name(
    ros_context: Any, tmp_path: Path
) -> None:
    layout = rectangular_patch("chest", "chest_link", 4, 4)
    save_layout(layout, tmp_path / "chest.yaml")
    with pytest.raises(ValueError, match=r"driver 'driver' reads patches \['chest'\]"):
        compose(["driver"], context=ros_context, overrides={
            "driver": driver_params(tmp_path / "none", tmp_path / "chest.yaml", 0.0),
            "contact_estimation": ESTIMATOR})


@pytest.mark.ros
def test_the_launch_command_of_the_composed_process_configures_each_node(
    tmp_path: Path,
) -> None:
    """real.launch.py's composed process, from its launch kwargs: the ``--drivers`` names,
    the parameter files and the node-scoped ``-p`` overrides reach each node under its name
    (the files' sections, the launch arguments' port, layouts and taxel rate), and the
    estimator does not subscribe to the taxel topics."""
    import rclpy
    from rclpy.context import Context

    from phri_bringup.cli.main import main as phri
    from phri_bringup.graph import nodes as graph

    assert phri(["layouts", str(tmp_path / "layouts")]) == 0
    ports = {name: str(tmp_path / f"{name}.pty") for name in graph.REAL_SKIN_PORTS}
    spec = next(s for s in graph.real_graph(ports, layout_dir=str(tmp_path / "layouts"),
                                            taxel_rate_hz=40.0) if s.nodes)
    kwargs = graph.launch_node_kwargs(spec)
    files = [a for f in kwargs["parameters"] for a in ("--params-file", f)]
    names = kwargs["arguments"][1:]
    context = Context()
    rclpy.init(args=["skin_contact_node", "--ros-args", *files, *kwargs["ros_arguments"]],
               context=context)
    nodes: list[Node] = []
    try:
        nodes = compose(names, context=context)
        by = {n.get_name(): n for n in nodes}
        assert set(by) == {*graph.REAL_SKIN_PORTS, graph.ESTIMATION}
        for name, patches in graph.REAL_SKIN_PORTS.items():
            driver = by[name]
            assert driver.get_parameter("port").value == ports[name]
            assert driver.get_parameter("taxel_publish_rate_hz").value == 40.0
            assert [Path(f).stem for f in driver.get_parameter("layout_files").value] == \
                list(patches)
            assert len(driver.get_parameter("board_ids").value) == len(patches)  # skin_real
        estimation = by[graph.ESTIMATION]
        assert estimation.get_parameter("subscribe_taxels").value is False
        real = graph.config_file("real")
        from phri_bringup.graph import parameter_files as params
        for key, value in params.load(real)[graph.ESTIMATION].items():
            actual = estimation.get_parameter(key).value
            assert (list(actual) if isinstance(value, list) else actual) == value, key
    finally:
        for node in reversed(nodes):
            node.destroy_node()
        rclpy.try_shutdown(context=context)
