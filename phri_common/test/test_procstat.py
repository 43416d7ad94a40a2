"""phri_common.procstat: process and machine CPU from /proc."""

from __future__ import annotations

import os
import subprocess
import sys
import time

import pytest

from phri_common.procstat import MachineCpu, load_line, process_cpu_s


def test_process_cpu_counts_a_busy_child_and_not_a_sleeping_one() -> None:
    busy = subprocess.Popen([sys.executable, "-c",
                             "import time\nend = time.process_time() + 0.6\n"
                             "while time.process_time() < end: pass\ntime.sleep(30)"])
    sleeper = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(30)"])
    try:
        deadline = time.monotonic() + 60.0  # bounds a stalled machine only
        while process_cpu_s(busy.pid) < 0.6 and time.monotonic() < deadline:
            time.sleep(0.05)
        used = process_cpu_s(busy.pid)
        assert 0.6 <= used < 2.0  # the spin plus the interpreter's start-up
        assert process_cpu_s(sleeper.pid) < 0.6
    finally:
        for p in (busy, sleeper):
            p.kill()
            p.wait()


def test_process_cpu_of_a_finished_process_raises_naming_the_pid() -> None:
    p = subprocess.Popen([sys.executable, "-c", "pass"])
    p.wait()
    with pytest.raises(ProcessLookupError, match=str(p.pid)):
        process_cpu_s(p.pid)


def test_machine_busy_cores_sees_this_process_spinning() -> None:
    before, wall0, cpu0 = MachineCpu.now(), time.monotonic(), time.process_time()
    while time.process_time() < cpu0 + 0.3:
        pass
    busy = MachineCpu.now().busy_cores_since(before)
    # This process alone kept 0.3 s / wall of a core busy (ticks: 10 ms resolution).
    floor = (time.process_time() - cpu0 - 0.02) / (time.monotonic() - wall0)
    assert floor * 0.9 <= busy <= (os.cpu_count() or 1) + 1e-9


def test_load_line_names_the_load_and_the_cores() -> None:
    line = load_line()
    assert line.startswith("load average ") and f"{os.cpu_count()} cores" in line
