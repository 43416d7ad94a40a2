"""Shared fixtures: isolated ROS domain per test process (see phri_common.testing), and a fake
RTDE server on 127.0.0.1:30004 for the tests that talk to it with the real ur_rtde client."""

import errno
from collections.abc import Iterator

import pytest

from phri_common.testing import configure_test_process, ros_context
from phri_hardware.fake_rtde import FakeRobotState, FakeRtdeServer

configure_test_process()

__all__ = ["ros_context"]

RTDE_Q = (0.1, -1.2, 1.3, -1.4, -1.5, 0.6)
"""Joint positions the fake robot reports [rad] (tests read them as ``rtde_server.state.q``)."""


@pytest.fixture
def rtde_server() -> Iterator[FakeRtdeServer]:
    """A fake RTDE server serving :data:`RTDE_Q` for at most 60 s; skips if the port is taken."""
    try:
        server = FakeRtdeServer(FakeRobotState(q=RTDE_Q), lifetime=60.0)
    except OSError as err:
        if err.errno == errno.EADDRINUSE:
            pytest.skip("127.0.0.1:30004 is in use (another RTDE server runs here)")
        raise
    with server:
        yield server
