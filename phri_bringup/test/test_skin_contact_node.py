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
    layout = rectangular_patch("forearm", "forearm_link", 6, 6)
    save_layout(layout, tmp_path / "forearm.yaml")
    port = tmp_path / "port"
    press = press_pattern(layout, force=4.0, radius=0.008, period=0.0)
    stop = threading.Event()
    board = threading.Thread(target=run_boards, daemon=True, args=(
        lambda: PtyEndpoint(port), [(SimBoard(4, layout, seed=0), press)], RATE, stop))
    board.start()
    while not port.exists():
        time.sleep(0.01)
    nodes = compose(["driver"], context=ros_context, overrides={
        "driver": driver_params(port, tmp_path / "forearm.yaml", 50.0),
        "contact_estimation": ESTIMATOR})
    peer = Node("peer", context=ros_context)
    states: list[PointCloud2] = []
    taxels: list[float] = []
    peer.create_subscription(PointCloud2, "contacts/forearm_link", states.append, 100)
    peer.create_subscription(PointCloud2, "skin/forearm/taxels",
                             lambda _m: taxels.append(time.monotonic()), 100)
    executor = SingleThreadedExecutor(context=ros_context)
    for node in [*nodes, peer]:
        executor.add_node(node)
    try:
        assert spin_until(executor, lambda: len(states) >= 50, timeout_s=15.0)
        s0, t0, start = len(states), len(taxels), time.monotonic()
        spin_until(executor, lambda: time.monotonic() - start > 2.0, timeout_s=3.0)
        elapsed = time.monotonic() - start
        state_rate, taxel_rate = (len(states) - s0) / elapsed, (len(taxels) - t0) / elapsed
        assert state_rate >= 0.6 * RATE, f"contact states at {state_rate:.0f} Hz"
        assert 25.0 <= taxel_rate <= 55.0, f"taxel arrays at {taxel_rate:.0f} Hz"
        state = msg_to_contact(states[-1])
        assert state.in_contact and state.link == "forearm_link"
        assert float(np.linalg.norm(state.force)) == pytest.approx(4.0, abs=0.05)
        # The estimator does not also take the (throttled) topic: only the peer listens.
        assert nodes[1].count_subscribers("skin/forearm/taxels") == 1
    finally:
        stop.set()
        board.join(5)
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
