"""Test helpers: isolated ROS domains and spinning until a condition holds.

Every test process picks its own ``ROS_DOMAIN_ID`` (from its pid) and restricts discovery to
localhost, so parallel test runs on one machine never hear each other (design §5).
"""

from __future__ import annotations

import difflib
import os
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path

import pytest

from phri_common.params import ParamSpec, markdown_table, table_in


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
