"""The colcon test summary fails packages that ran nothing (phri_common.junit_summary)."""

from __future__ import annotations

from pathlib import Path

import pytest

from phri_common.junit_summary import check, main, read_counts


def _write(base: Path, package: str, body: str) -> None:
    (base / package).mkdir(parents=True)
    (base / package / "pytest.xml").write_text(body, encoding="utf-8")


SUITE = ('<?xml version="1.0"?><testsuites><testsuite name="pytest" tests="{t}" failures="{f}" '
         'errors="0" skipped="{s}"></testsuite></testsuites>')


def test_counts_and_closing_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    _write(tmp_path, "a", SUITE.format(t=5, f=0, s=1))
    _write(tmp_path, "b", SUITE.format(t=3, f=0, s=0))
    assert main([str(tmp_path), "a", "b"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[-1] == "7 passed, 0 failed, 1 skipped"
    assert read_counts(tmp_path / "a" / "pytest.xml").passed == 4


@pytest.mark.parametrize(("body", "reason"), [
    (SUITE.format(t=0, f=0, s=0), "ran 0 tests"),
    (SUITE.format(t=4, f=1, s=0), "1 failures"),
    ("not xml", "no test result"),
])
def test_a_bad_package_fails_the_run(tmp_path: Path, body: str, reason: str) -> None:
    _write(tmp_path, "good", SUITE.format(t=2, f=0, s=0))
    _write(tmp_path, "bad", body)
    problems, _ = check(tmp_path, ["good", "bad"])
    assert len(problems) == 1 and problems[0].startswith("bad: ") and reason in problems[0]
    assert main([str(tmp_path), "good", "bad"]) == 1


def test_a_package_without_results_fails(tmp_path: Path) -> None:
    problems, sums = check(tmp_path, ["absent"])
    assert problems and "absent: no test result" in problems[0] and sums.tests == 0


def test_colcon_dummy_result_counts_as_an_error(tmp_path: Path) -> None:
    """colcon writes this placeholder before pytest runs; it must not pass."""
    _write(tmp_path, "p", '<testsuite name="p" tests="1" failures="0" time="0" errors="1" '
                          'skipped="0"><testcase name="pytest.missing_result"/></testsuite>')
    problems, _ = check(tmp_path, ["p"])
    assert problems == ["p: 0 failures, 1 errors"]
