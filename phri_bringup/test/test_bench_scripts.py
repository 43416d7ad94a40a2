"""Every ``bench/`` script runs as documented from a fresh clone.

Each script is started the way docs/benchmarks.md shows,
``.venv/bin/python bench/<script>.py``, in a subprocess whose working directory is NOT the
repository and whose environment has no ``PYTHONPATH``: a script that imports anything but the
installed packages (e.g. the ``bench`` directory as a package) fails here. ``--help`` imports
every module-level dependency; the pure benchmarks also run a few iterations.
"""

from __future__ import annotations

import importlib.util
import os
import re
import subprocess
import sys
from pathlib import Path
from types import ModuleType

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
SCRIPTS = sorted(p.name for p in (ROOT / "bench").glob("bench_*.py"))
SMOKE = {"bench_kinematics.py": ["--iterations", "20"]}


def bench_chain() -> ModuleType:
    """bench/bench_chain.py loaded as a module (``bench/`` is no package)."""
    spec = importlib.util.spec_from_file_location("bench_chain", ROOT / "bench" / "bench_chain.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def run_script(name: str, args: list[str], cwd: Path) -> subprocess.CompletedProcess[str]:
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    return subprocess.run(
        [sys.executable, str(ROOT / "bench" / name), *args],
        cwd=cwd, env=env, capture_output=True, text=True, timeout=120, check=False,
    )


def test_there_are_bench_scripts() -> None:
    assert "bench_chain.py" in SCRIPTS and len(SCRIPTS) >= 7


@pytest.mark.parametrize("name", SCRIPTS)
def test_bench_script_help_runs_without_pythonpath(name: str, tmp_path: Path) -> None:
    result = run_script(name, ["--help"], tmp_path)
    assert result.returncode == 0, result.stderr[-2000:]
    assert result.stdout.startswith("usage:"), result.stdout[:500]


@pytest.mark.parametrize("name", sorted(SMOKE))
def test_pure_bench_script_runs_a_few_iterations(name: str, tmp_path: Path) -> None:
    result = run_script(name, SMOKE[name], tmp_path)
    assert result.returncode == 0, result.stderr[-2000:]
    assert "median" in result.stdout


def test_benchmarks_page_documents_every_bench_script_and_only_existing_ones() -> None:
    page = (ROOT / "docs" / "benchmarks.md").read_text()
    named = set(re.findall(r"\b(bench_\w+\.py)", page))
    assert named == set(SCRIPTS)


def test_bench_chain_probe_wraps_methods_the_controller_node_has() -> None:
    """bench_chain.py's controller probe overrides node methods; if one is renamed the probe
    records nothing and every frame reads as dropped (it happened: _on_contact was renamed)."""
    from wholebody_controller.node import WholeBodyControllerNode

    module = bench_chain()
    for method in module.PROBED_METHODS:
        assert callable(getattr(WholeBodyControllerNode, method, None)), method


def test_bench_chain_expected_forces_follow_the_drivers_window() -> None:
    """The force code a contact state is matched with: the mean of the last 10 frames that
    reached the driver — a frame cut off at the full pty is skipped, and a board silence longer
    than the driver's timeout restarts the window (else one lost frame would make the next ten
    read as dropped)."""
    module = bench_chain()
    pressed = np.arange(1, 31, dtype=np.int64) * 100
    plain = module.expected_forces(pressed)
    assert plain[0] == 100 and plain[9] == 550 and plain[29] == 2550  # means of 1..k, last 10
    cut = np.zeros(30, dtype=np.int64)
    cut[12] = 1
    skipped = module.expected_forces(pressed, cut=cut)
    assert skipped[11] == plain[11] and skipped[14] == (np.sum(pressed[4:15]) - 1300) / 10
    board_ns = np.arange(30) * 2_000_000
    board_ns[20:] += 200_000_000
    restarted = module.expected_forces(pressed, cut=cut, board_ns=board_ns)
    assert restarted[20] == 2100 and restarted[22] == 2200 and restarted[19] == skipped[19]


def test_bench_chain_matches_every_state_to_its_own_frame_across_the_code_wrap() -> None:
    """Contact states stamped within a few ms of their frame and carrying its expected force
    are matched to exactly that frame, also where the force code wraps (MODULUS frames) and the
    moving average revisits values nearby frames also take."""
    module = bench_chain()
    period = 2_000_000
    n = 3 * module.MODULUS
    board = np.arange(n, dtype=np.int64) * period
    pressed = np.round((module.F0 + module.DELTA * (np.arange(n) % module.MODULUS)) * 1e6)
    offset = 5_000_000_000
    sent = np.column_stack([board, board + offset + 300_000, pressed.astype(np.int64),
                            np.zeros(n, dtype=np.int64)])
    expected = module.expected_forces(sent[:, 2])
    jitter = np.random.default_rng(0).integers(-3_000_000, 3_000_000, n)  # stamp error [ns]
    found = module.match_frames(board + offset + 300_000 + jitter, expected, sent, period)
    np.testing.assert_array_equal(found, np.arange(n))


def test_bench_chain_composed_probe_wraps_what_the_estimation_node_has() -> None:
    """The composed probe overrides ``on_frame`` and swaps the contact-state publishers: a
    rename would make it record nothing (every state would read as never published)."""
    from contact_estimation.node import ContactEstimationNode

    module = bench_chain()
    for method in module.PROBED_ESTIMATION_METHODS:
        assert callable(getattr(ContactEstimationNode, method, None)), method
    init = ContactEstimationNode.__init__.__code__
    assert "_state_pubs" in init.co_names


def test_bench_chain_counts_lost_states_by_stamp_whatever_the_arrival_order() -> None:
    """Published stamps missing from the received ones, exactly: late, reordered and repeated
    arrivals count as received; a contiguous burst of missing ones is reported in order."""
    module = bench_chain()
    published = np.arange(100, dtype=np.int64) * 2_000_000 + 7
    received = np.concatenate([published[:40], published[75:][::-1], published[:3]])
    assert module.lost_stamps(published, received) == published[40:75].tolist()
    assert module.lost_stamps(published, published[::-1]) == []
