"""Shared fixtures: isolated ROS domain per test process (see phri_common.testing)."""

from phri_common.testing import (
    isolate_ros_environment,
    register_hypothesis_profiles,
    ros_context,
)

isolate_ros_environment()
register_hypothesis_profiles()

__all__ = ["ros_context"]
