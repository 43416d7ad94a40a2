"""CPU use of processes and of the whole machine from ``/proc`` (Linux; pure, no rclpy).

Benchmarks print these beside their timings: on a machine shared with other jobs a latency is
only meaningful together with how busy the machine was. ``process_cpu_s`` reads utime + stime
of ``/proc/<pid>/stat`` (fields 14 and 15, in clock ticks); ``MachineCpu`` reads the first
line of ``/proc/stat`` (all cores, ticks spent per state) and reports the busy share between
two snapshots: busy = all states except idle and iowait.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

TICKS_PER_S = float(os.sysconf("SC_CLK_TCK"))
"""Kernel clock ticks per second (``/proc`` CPU counters are in these)."""


def process_cpu_s(pid: int) -> float:
    """CPU time [s] (user + system) the process ``pid`` has used so far.

    Raises:
        ProcessLookupError: no such process (it exited).
    """
    try:
        text = Path(f"/proc/{pid}/stat").read_text()
    except FileNotFoundError as err:
        raise ProcessLookupError(f"pid {pid}: no such process") from err
    # The command name (field 2) may contain spaces: split after its closing parenthesis.
    fields = text.rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / TICKS_PER_S


@dataclass(frozen=True)
class MachineCpu:
    """A snapshot of the machine's CPU counters (all cores) [ticks]."""

    busy: int
    total: int

    @staticmethod
    def now() -> MachineCpu:
        """Read ``/proc/stat`` now."""
        values = [int(x) for x in Path("/proc/stat").read_text().split("\n", 1)[0].split()[1:]]
        idle = values[3] + (values[4] if len(values) > 4 else 0)  # idle + iowait
        total = sum(values[:8])  # user … steal; guest time is already inside user
        return MachineCpu(busy=total - idle, total=total)

    def busy_cores_since(self, earlier: MachineCpu) -> float:
        """Average number of busy cores between ``earlier`` and this snapshot [cores]."""
        total = self.total - earlier.total
        if total <= 0:
            return 0.0
        cores = os.cpu_count() or 1
        return cores * (self.busy - earlier.busy) / total


def load_line() -> str:
    """One line for a benchmark's output: load averages and core count."""
    one, five, fifteen = os.getloadavg()
    return f"load average {one:.2f} / {five:.2f} / {fifteen:.2f} (1 / 5 / 15 min), " \
        f"{os.cpu_count()} cores"


__all__ = ["TICKS_PER_S", "MachineCpu", "load_line", "process_cpu_s"]
