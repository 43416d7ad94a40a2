"""Benchmark: the whole-process pauses that dropped the chain's frames, without and with settle.

In a fresh process holding the controller node (its imports: rclpy, numpy, numba, MuJoCo), as
``run_nodes`` starts it, this times [ms]:

* a full (generation-2) garbage collection — CPython walks every tracked object;
* rclpy's first logger call from a new call site, and the median of the next ones (a throttled
  warning: rclpy looks its caller up with ``inspect`` on every call, printed or not);

once without :func:`phri_common.settle.settle` and once, in another fresh process, after it
(what ``run_nodes`` now does). docs/benchmarks.md, "Pauses", quotes this script.

Run: ``.venv/bin/python bench/bench_pauses.py [--repeat 5]``.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from phri_common.procstat import load_line

CHILD = """
import gc, json, statistics, sys, time
import rclpy
from phri_common.settle import settle
from wholebody_controller.node import WholeBodyControllerNode

rclpy.init()
node = WholeBodyControllerNode()
tracked = len(gc.get_objects())
if sys.argv[1] == "settled":
    settle()
logger = node.get_logger()

def warn():
    logger.warning("bench_pauses", throttle_duration_sec=10.0)

t = time.perf_counter(); warn(); first = time.perf_counter() - t
later = []
for _ in range(20):
    t = time.perf_counter(); warn(); later.append(time.perf_counter() - t)
t = time.perf_counter(); gc.collect(); full = time.perf_counter() - t
print(json.dumps({"tracked": tracked, "full_gc": full, "first_log": first,
                  "later_log": statistics.median(later)}))
node.destroy_node()
rclpy.try_shutdown()
"""


def measure(script: Path, mode: str) -> dict[str, float]:
    """One fresh process: ``mode`` 'plain' or 'settled'."""
    out = subprocess.run([sys.executable, str(script), mode], capture_output=True, text=True,
                         timeout=120, check=True).stdout
    return dict(json.loads(out.strip().splitlines()[-1]))


def main() -> int:
    p = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    p.add_argument("--repeat", type=int, default=5, help="fresh processes per mode")
    args = p.parse_args()
    print(load_line())
    rows: dict[str, list[dict[str, float]]] = {"plain": [], "settled": []}
    with tempfile.TemporaryDirectory(prefix="bench_pauses_") as tmp:
        script = Path(tmp) / "child.py"  # a file, as a node's log call sites are
        script.write_text(CHILD)
        for _ in range(args.repeat):  # interleaved: both modes see the same machine load
            for mode in rows:
                rows[mode].append(measure(script, mode))
                time.sleep(0.2)
    print(f"controller node process, {int(rows['plain'][0]['tracked'])} tracked objects; "
          f"median of {args.repeat} fresh processes [ms]")
    print("| process | full collection | first log call | later log calls (median) |")
    print("|---|---:|---:|---:|")
    for mode, runs in rows.items():
        med = {k: sorted(r[k] for r in runs)[len(runs) // 2] * 1e3 for k in runs[0]}
        print(f"| {mode} | {med['full_gc']:.1f} | {med['first_log']:.1f} | "
              f"{med['later_log']:.2f} |")
    print(load_line())
    return 0


if __name__ == "__main__":
    sys.exit(main())
