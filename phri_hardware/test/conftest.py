"""Shared fixtures: isolated ROS domain per test process (see phri_common.testing)."""

from phri_common.testing import isolate_ros_environment, ros_context

isolate_ros_environment()

__all__ = ["ros_context"]
