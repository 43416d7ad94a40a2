"""phri_common.settle through run_nodes: a node process's one-off pauses are paid at start-up.

The child runs ``run_nodes`` with a timer node; its first callback reports what the collector
and ``inspect`` hold by then. Without ``settle`` the start-up objects are still in the
collector's generations (a full collection walks them all: the 50–150 ms pauses that dropped
contact states in bench_chain) and ``inspect`` has resolved no module file (rclpy's first log
call then resolves them all: 60–400 ms).
"""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap

CHILD = textwrap.dedent("""
    import gc, inspect, json, os, signal, sys
    import rclpy
    import rclpy.node
    from phri_common.ros_main import run_nodes

    class Probe(rclpy.node.Node):
        def __init__(self):
            super().__init__("settle_probe")
            self.tracked_at_start = len(gc.get_objects())
            self.create_timer(0.01, self.first)
            self.done = False

        def first(self):
            if self.done:
                return
            self.done = True
            print(json.dumps({
                "tracked_at_start": self.tracked_at_start,
                "frozen": gc.get_freeze_count(),
                "young": len(gc.get_objects()),
                "rclpy_node_resolved": os.path.realpath(rclpy.node.__file__)
                    in inspect.modulesbyfile,
            }), flush=True)
            os.kill(os.getpid(), signal.SIGINT)

    sys.exit(run_nodes(lambda: [Probe()], "settle_probe"))
""")


def run_child() -> dict[str, int]:
    proc = subprocess.run([sys.executable, "-c", CHILD], capture_output=True, text=True,
                          timeout=60)
    assert proc.returncode == 0, proc.stderr[-2000:]
    return dict(json.loads(proc.stdout.strip().splitlines()[-1]))


def test_start_up_objects_are_frozen_and_module_files_resolved_before_the_first_callback(
) -> None:
    report = run_child()
    # Every object alive when the node was built is out of the collector's generations: a full
    # collection in the loop walks only what was allocated since (a few thousand at most).
    assert report["frozen"] >= 0.9 * report["tracked_at_start"]
    assert report["young"] < 0.1 * report["tracked_at_start"]
    # rclpy's logger resolves its caller through inspect.getmodule: already cached.
    assert report["rclpy_node_resolved"]
