"""Shared fixtures: isolated ROS domain per test process (see phri_common.testing)."""

from phri_common.testing import configure_test_process, ros_context

configure_test_process()

__all__ = ["ros_context"]
