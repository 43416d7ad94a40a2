"""Shared fixtures: isolated ROS domain per test process (see phri_common.testing).

The test folder goes on ``sys.path`` so tests can import the MuJoCo-free
``wbc_fake_kinematics`` stand-in (pytest runs with ``--import-mode=importlib``).
"""

import sys
from pathlib import Path

from phri_common.testing import isolate_ros_environment, ros_context

sys.path.insert(0, str(Path(__file__).parent))
isolate_ros_environment()

__all__ = ["ros_context"]
