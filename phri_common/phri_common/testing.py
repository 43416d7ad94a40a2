"""Test helpers: isolated ROS domains, spinning until a condition holds, hypothesis profiles,
generated files compared with their generator.

Every test process picks its own ``ROS_DOMAIN_ID`` (from its pid) and restricts discovery to
localhost, so parallel test runs on one machine never hear each other (design §5).

Importing this module (every package's ``conftest.py`` does, first) also keeps OpenBLAS to one
thread in the test process unless ``OPENBLAS_NUM_THREADS`` is set: the suite runs packages in
parallel on two cores, where OpenBLAS's spinning worker threads made each small LAPACK call
(scipy's 6×6 ``expm`` in the reference step) about five times slower.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # before numpy loads OpenBLAS

import ast
import difflib
import math
import re
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path

import pytest
from hypothesis import Phase, settings

from phri_common.params import ParamSpec, markdown_table, table_in

HYPOTHESIS_PROFILES = {"ci": 100, "deep": 1000}
"""The suite's hypothesis profiles and their base number of examples per property test. "ci"
(the default: what ``./test.sh``, ``colcon test`` and CI run) is derandomized, so every run
draws the same examples and a CI failure reproduces locally; "deep" (``pytest
--hypothesis-profile=deep``) draws ten times as many, at random, for a run before a release.
Every profile prints a failing example with its ``@reproduce_failure`` blob."""


def register_hypothesis_profiles() -> None:
    """Register :data:`HYPOTHESIS_PROFILES` and load "ci" (each package's ``conftest.py``;
    ``--hypothesis-profile`` or ``HYPOTHESIS_PROFILE`` choose another)."""
    # No "explain" phase: it traces every line of a failing example again (hypothesis' scrutineer),
    # which turned one failure of a long equivalence test into a 300 s timeout on a busy machine.
    phases = [p for p in Phase if p is not Phase.explain]
    for name, examples in HYPOTHESIS_PROFILES.items():
        settings.register_profile(name, max_examples=examples, derandomize=name == "ci",
                                  deadline=None, print_blob=True, phases=phases)
    settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))


def configure_test_process() -> None:
    """What every package's ``conftest.py`` does first: an isolated ROS domain and the suite's
    hypothesis profiles."""
    isolate_ros_environment()
    register_hypothesis_profiles()


def examples(factor: float) -> int:
    """``factor`` times the loaded profile's examples per test: for property tests that guard
    the controller and need more than the base number (or fewer, being slow), so that "deep"
    scales them too."""
    current = settings.default
    base = current.max_examples if current is not None else HYPOTHESIS_PROFILES["ci"]
    return max(1, round(factor * base))


def isolated_domain_id() -> int:
    """A ROS domain id for this process: 1…100, derived from the pid."""
    return 1 + os.getpid() % 100


def isolate_ros_environment() -> int:
    """Set ``ROS_DOMAIN_ID`` and localhost-only discovery for this process; return the id."""
    domain = int(os.environ.setdefault("PHRI_TEST_DOMAIN_ID", str(isolated_domain_id())))
    os.environ["ROS_DOMAIN_ID"] = str(domain)
    os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    return domain


@contextmanager
def ros_context_scope() -> Iterator[object]:
    """An initialised, isolated ``rclpy.Context``; shut down on exit."""
    import rclpy
    from rclpy.context import Context

    domain = isolate_ros_environment()
    context = Context()
    rclpy.init(context=context, domain_id=domain)
    try:
        yield context
    finally:
        context.try_shutdown()


@pytest.fixture
def ros_context() -> Iterator[object]:
    """Pytest fixture: an isolated ``rclpy.Context`` for one test."""
    with ros_context_scope() as context:
        yield context


def spin_until(
    executor: object, condition: Callable[[], bool], timeout_s: float = 5.0, step_s: float = 0.01
) -> bool:
    """Spin ``executor`` until ``condition()`` holds or ``timeout_s`` passes; return it."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if condition():
            return True
        executor.spin_once(timeout_sec=step_s)  # type: ignore[attr-defined]
    return condition()


def assert_parameter_table(doc: Path, specs: Sequence[ParamSpec]) -> None:
    """Fail unless ``doc`` holds exactly the parameter table of ``specs``: every row (name, type,
    unit, default, range, description) equal to :func:`~phri_common.params.markdown_table`'s, in
    the same order, with no row missing or left over. The message is a diff (- docs, + code)."""
    expected = markdown_table(specs)
    found = table_in(doc.read_text(encoding="utf-8"), specs[0].name)
    if found != expected:
        diff = "\n".join(difflib.unified_diff(found.splitlines(), expected.splitlines(),
                                               "docs", "code", lineterm="", n=0))
        pytest.fail(f"{doc.name}: the parameter table differs from the code "
                    f"(- docs, + code):\n{diff}")


_NUMBER = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")


def generated_text_differences(stored: str, generated: str, tolerance: float) -> list[str]:
    """Lines where two generated text files differ beyond their numbers' last digits.

    Text outside numbers must be equal; numbers a, b must satisfy
    ``|a − b| ≤ tolerance · max(1, |a|, |b|)`` (so ``9.97e-20`` against ``0`` is no difference:
    arithmetic noise of another machine, not a change). Returns ``line N: stored | generated``
    for each differing line (all lines when the line counts differ).
    """
    a_lines, b_lines = stored.splitlines(), generated.splitlines()
    if len(a_lines) != len(b_lines):
        return [f"{len(a_lines)} lines stored, {len(b_lines)} generated"]
    out = []
    for number, (a, b) in enumerate(zip(a_lines, b_lines, strict=True), start=1):
        if a == b:
            continue
        same = _NUMBER.split(a) == _NUMBER.split(b)
        xs, ys = _NUMBER.findall(a), _NUMBER.findall(b)
        same = same and len(xs) == len(ys) and all(
            abs(float(x) - float(y)) <= tolerance * max(1.0, abs(float(x)), abs(float(y)))
            or (math.isnan(float(x)) and math.isnan(float(y)))
            for x, y in zip(xs, ys, strict=True))
        if not same:
            out.append(f"line {number}: {a.strip()} | {b.strip()}")
    return out


def assert_generated_file(stored: Path, generated: str, regenerate: str,
                          tolerance: float = 1e-8) -> None:
    """Fail unless the checked-in file ``stored`` is ``generated`` (numbers to ``tolerance``,
    :func:`generated_text_differences`); the message says which command regenerates it."""
    differences = generated_text_differences(stored.read_text(encoding="utf-8"), generated,
                                             tolerance)
    if differences:
        shown = "\n".join(differences[:10])
        pytest.fail(f"{stored} differs from what its generator writes now; if the change is "
                    f"intended, run `{regenerate}` and commit the file:\n{shown}")


def _imported_modules(tree: ast.AST) -> Iterator[str]:
    """The absolute module paths ``import`` and ``from … import`` statements name (also inside
    functions): ``from a.b import c`` gives ``a.b``; ``from a import b`` gives ``a.b`` (``b``
    may be a subpackage)."""
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            yield from (alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            if "." in node.module:
                yield node.module
            else:
                yield from (f"{node.module}.{alias.name}" for alias in node.names)


def layer_violations(package_dir: Path, layers: Sequence[str], above: Sequence[str] = ()
                     ) -> list[str]:
    """Imports that go up the layers of a Python package: one line per offending import.

    Args:
        package_dir: the package's folder (``<pkg>/<pkg>``); its subpackages are its layers.
        layers: subpackage names, lowest first: a module of one may import only from its own
            layer and the ones before it. A top-level module of the package counts as above
            every layer, and a subpackage not listed is an error (the list must stay complete).
        above: packages above this one (none of their modules may be imported).
    """
    package = package_dir.name
    rank = {name: i for i, name in enumerate(layers)}
    top = len(layers)
    problems = [f"{sub.name}/ is not in the layer list"
                for sub in sorted(package_dir.iterdir())
                if (sub / "__init__.py").is_file() and sub.name not in rank]
    for path in sorted(package_dir.rglob("*.py")):
        relative = path.relative_to(package_dir)
        own = rank.get(relative.parts[0], top) if len(relative.parts) > 1 else top
        for module in _imported_modules(ast.parse(path.read_text(encoding="utf-8"))):
            parts = module.split(".")
            if parts[0] in above:
                problems.append(f"{relative}: imports {module} (package {parts[0]} is above)")
            elif parts[0] == package and len(parts) > 1 and parts[1] in rank \
                    and rank[parts[1]] > own:
                problems.append(f"{relative}: imports {module} (layer {parts[1]} is above "
                                f"{relative.parts[0]})")
            elif parts[0] == package and len(parts) == 2 and own < top \
                    and (package_dir / f"{parts[1]}.py").is_file():
                problems.append(f"{relative}: imports {module} (a top-level module)")
    return sorted(set(problems))
