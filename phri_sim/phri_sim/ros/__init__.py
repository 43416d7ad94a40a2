"""The simulator on ROS 2: the bridge node and the in-process lock-step runner."""
