"""Pay a node process's one-off Python pauses at start-up instead of inside its 500 Hz loop.

``bench/bench_chain.py`` traced every contact state the chain lost (docs/benchmarks.md, "End to
end") to a
whole process stopping for longer than its queues last (contact states: 25 deep, 50 ms at
500 Hz; the skin pty: ≈ 18 ms before the board cuts a frame off), from two causes that are
neither DDS nor the executor:

* **full garbage collections.** A node process holds ≈ 150,000 tracked objects after its
  imports (rclpy, numpy, numba, MuJoCo) and start-up; CPython 3.11 walks them all in every
  generation-2 collection, tens to hundreds of milliseconds, once or twice a minute at first.
  ``gc.freeze()`` after start-up moves them to the permanent generation: a full collection
  then walks only what was allocated since (docs/benchmarks.md, "Pauses").
* **the first rclpy log call.** rclpy's logger looks its caller up with
  ``inspect.getframeinfo`` on every call (throttled calls too), and the first such lookup in a
  process makes ``inspect.getmodule`` resolve the path of every loaded module (≈ 1,100), e.g.
  on a node's first "stale input" warning. Doing that lookup here fills ``inspect``'s module
  cache; later log calls still cost too much for a call in every cycle (log from the loop only
  when a message is due; docs/benchmarks.md, "End to end").

:func:`settle` does both; ``phri_common.ros_main.run_nodes`` calls it once the nodes exist,
before the first executor slice.
"""

from __future__ import annotations

import gc
import inspect
import sys
from dataclasses import dataclass


@dataclass(frozen=True)
class Settled:
    """What :func:`settle` did.

    Attributes:
        frozen: objects in the permanent generation afterwards (``gc.get_freeze_count()``).
        modules: modules whose file ``inspect`` had resolved afterwards.
    """

    frozen: int
    modules: int


def settle() -> Settled:
    """Resolve every loaded module's file in ``inspect``'s cache, collect, freeze what is left.

    Call once, after start-up (imports, nodes created) and before the real-time loop: it takes
    as long as the pauses it removes (docs/benchmarks.md, "Pauses"). Objects allocated later
    are collected as usual.
    """
    inspect.getmodule(sys._getframe())  # fills inspect.modulesbyfile for every loaded module
    gc.collect()
    gc.freeze()
    return Settled(frozen=gc.get_freeze_count(), modules=len(inspect.modulesbyfile))
