"""Summary of a ``colcon test`` run from its JUnit files, failing packages that ran no test.

colcon writes one ``<build-base>/<package>/pytest.xml`` per package. ``colcon test`` alone
passes a package whose pytest collected nothing (or that silently fell back to unittest and ran
0 tests), so ``test.sh`` calls this afterwards:

    python -m phri_common.junit_summary build phri_common skin_driver ...

It prints one line per package and a closing ``N passed, N failed, N skipped`` line, and exits
with 1 when any package is missing its result file, ran 0 tests, or has a failure or error.
"""

from __future__ import annotations

import sys
import xml.etree.ElementTree as ET
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path


@dataclass(frozen=True)
class Counts:
    """Test counts of one package (JUnit ``testsuite`` attributes, summed over suites)."""

    tests: int = 0
    failures: int = 0
    errors: int = 0
    skipped: int = 0

    @property
    def passed(self) -> int:
        return self.tests - self.failures - self.errors - self.skipped


def read_counts(path: Path) -> Counts:
    """Counts of a JUnit XML file (root ``testsuites`` or a single ``testsuite``).

    Raises:
        FileNotFoundError: no such file.
        ValueError: the file is not JUnit XML (names the file).
    """
    try:
        root = ET.parse(path).getroot()
    except ET.ParseError as exc:
        raise ValueError(f"{path}: not a JUnit XML file ({exc})") from exc
    suites = [root] if root.tag == "testsuite" else root.findall("testsuite")
    if root.tag not in ("testsuite", "testsuites"):
        raise ValueError(f"{path}: root element {root.tag!r}, expected testsuite(s)")

    def total(key: str) -> int:
        return sum(int(s.get(key, "0")) for s in suites)

    return Counts(total("tests"), total("failures"), total("errors"), total("skipped"))


def check(build_base: Path, packages: Sequence[str]) -> tuple[list[str], Counts]:
    """Problems (one line each) and the summed counts of ``packages`` under ``build_base``."""
    problems: list[str] = []
    sums = Counts()
    for package in packages:
        path = build_base / package / "pytest.xml"
        try:
            counts = read_counts(path)
        except (FileNotFoundError, ValueError) as exc:
            problems.append(f"{package}: no test result ({exc})")
            continue
        print(f"{package}: {counts.passed} passed, {counts.failures + counts.errors} failed, "
              f"{counts.skipped} skipped")
        if counts.tests == 0:
            problems.append(f"{package}: ran 0 tests (is pytest its test dependency, and does "
                            "its test/ directory hold test_*.py files?)")
        if counts.failures or counts.errors:
            problems.append(f"{package}: {counts.failures} failures, {counts.errors} errors")
        sums = Counts(sums.tests + counts.tests, sums.failures + counts.failures,
                      sums.errors + counts.errors, sums.skipped + counts.skipped)
    return problems, sums


def main(argv: Sequence[str] | None = None) -> int:
    args = list(sys.argv[1:] if argv is None else argv)
    if len(args) < 2:
        print("usage: python -m phri_common.junit_summary BUILD_BASE PACKAGE...", file=sys.stderr)
        return 2
    problems, sums = check(Path(args[0]), args[1:])
    for problem in problems:
        print(f"FAILED {problem}")
    print(f"{sums.passed} passed, {sums.failures + sums.errors} failed, {sums.skipped} skipped")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
