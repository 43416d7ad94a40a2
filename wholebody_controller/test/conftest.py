"""Shared fixtures: isolated ROS domain per test process (see phri_common.testing), and the
kinematics the controller's behaviour tests run on.

The test folder goes on ``sys.path`` so tests can import the MuJoCo-free
``wbc_fake_kinematics`` stand-in and the test helpers (pytest runs with
``--import-mode=importlib``).
"""

import sys
from pathlib import Path

import pytest

from phri_common.testing import configure_test_process, ros_context

sys.path.insert(0, str(Path(__file__).parent))
configure_test_process()

from wbc_fake_kinematics import FakeKinematics  # noqa: E402  (needs the path above)

from wholebody_controller.controller import KinematicsModel  # noqa: E402

__all__ = ["ros_context"]


@pytest.fixture(scope="session")
def robot_kinematics() -> KinematicsModel:
    """The real robot (phri_description through MuJoCo), built once for the whole test run.

    Stateful (``update(q)``): every user sets its own configuration before querying it.
    """
    from wholebody_controller.kinematics import RobotKinematics

    return RobotKinematics()


@pytest.fixture(params=["robot", "dh_fake"])
def kin(request: pytest.FixtureRequest, robot_kinematics: KinematicsModel) -> KinematicsModel:
    """Each behaviour test runs on the real robot description and on an independent D-H robot
    written from the UR16e table in numpy (``wbc_fake_kinematics``)."""
    if request.param == "robot":
        return robot_kinematics
    return FakeKinematics()
