"""``python -m phri_bringup.skin_contact_node``: skin drivers and contact estimation, one process.

The deployed chain runs one ``skin_driver_node`` per serial port and one
``contact_estimation_node``; every skin frame then crosses DDS as a taxel array (serialise,
deliver, deserialise, one executor dispatch: most of the estimation node's CPU per frame,
``bench/bench_chain.py``). Composed here, each driver's serial thread hands every calibrated
frame straight to the estimator (``SkinDriverNode.add_frame_listener`` →
``ContactEstimationNode.on_frame``), which publishes the contact states exactly as the separate
node does. One thread reads every driver's port (``skin_driver.transport.PortPoller``): three
serial threads waking per frame and contending for the GIL cost more per frame
(docs/benchmarks.md, "Skin driver"). The
taxel topics are still published, at each driver's ``taxel_publish_rate_hz``
(for rviz, recording and diagnostics tools); the estimator does not subscribe to them
(``subscribe_taxels`` is false).

Run::

    python -m phri_bringup.skin_contact_node --drivers skin_driver_0 skin_driver_1 \\
        --ros-args -p skin_driver_0:port:=/dev/ttyACM0 -p skin_driver_0:layout_files:=[...] \\
        -p skin_driver_0:taxel_publish_rate_hz:=50.0 ...

Each driver node takes its parameters under its own name; the estimator is the node
``contact_estimation``. Interface: docs/bringup.md.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Mapping, Sequence

from rclpy.context import Context
from rclpy.node import Node
from rclpy.parameter import Parameter

from contact_estimation.node import ContactEstimationNode
from phri_common.ros_main import run_nodes
from skin_driver.node import SkinDriverNode
from skin_driver.transport import PortPoller


def compose(
    driver_names: Sequence[str],
    *,
    context: Context | None = None,
    overrides: Mapping[str, list[Parameter]] | None = None,
) -> list[Node]:
    """The estimation node and one driver node per name, drivers feeding the estimator.

    ``overrides`` maps a node name (a driver's, or ``contact_estimation``) to parameter
    overrides (tests; processes take parameters from ``--ros-args``).

    Raises:
        ValueError: no driver, duplicate names, or a driver patch the estimator does not know
            (names the patch and the estimator's ``patches``).
    """
    if not driver_names or len(set(driver_names)) != len(driver_names):
        raise ValueError(f"--drivers refused {list(driver_names)}: allowed ≥ 1 unique node names")
    extra = dict(overrides or {})
    estimation = ContactEstimationNode(
        context=context,
        parameter_overrides=[*extra.get("contact_estimation", []),
                             Parameter("subscribe_taxels", value=False)],
    )
    nodes: list[Node] = [estimation]
    poller = PortPoller("skin_contact:serial")
    try:
        for name in driver_names:
            driver = SkinDriverNode(node_name=name, context=context,
                                    parameter_overrides=extra.get(name), poller=poller)
            nodes.append(driver)
            unknown = [p for p in driver.patches if p not in estimation.patches]
            if unknown:
                raise ValueError(
                    f"driver {name!r} reads patches {unknown} that the estimator's parameter "
                    f"'patches' {list(estimation.patches)} does not list"
                )
            driver.add_frame_listener(estimation.on_frame)
    except Exception:
        for node in reversed(nodes):
            node.destroy_node()
        raise
    return nodes


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point: ``--drivers NAME …`` before ``--ros-args``; runs until SIGINT/SIGTERM."""
    args = list(sys.argv if argv is None else argv)
    ours = args[1 : args.index("--ros-args")] if "--ros-args" in args else args[1:]
    parser = argparse.ArgumentParser(prog="skin_contact_node",
                                     description=(__doc__ or "").splitlines()[0])
    parser.add_argument("--drivers", nargs="+", default=["skin_driver"],
                        help="node names of the skin drivers (one per serial port)")
    names = parser.parse_args(ours).drivers
    return run_nodes(lambda: compose(names), "skin_contact_node", args)


if __name__ == "__main__":
    sys.exit(main())
