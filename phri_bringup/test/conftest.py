"""Shared fixtures: isolated ROS domain per test process (see phri_common.testing). The test
folder goes on ``sys.path`` so a test can import another's helpers (pytest runs with
``--import-mode=importlib``). Offscreen rendering is EGL's unless the environment says
otherwise (as ``test.sh`` does): MuJoCo picks its GL backend once, at its first import."""

import os
import sys
from pathlib import Path

from phri_common.testing import configure_test_process, ros_context

os.environ.setdefault("MUJOCO_GL", "egl")
sys.path.insert(0, str(Path(__file__).parent))
configure_test_process()

__all__ = ["ros_context"]
