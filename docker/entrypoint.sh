#!/usr/bin/env bash
# Source ROS and the phri workspace, then run the command.
set -e
# shellcheck disable=SC1091
source /opt/ros/kilted/setup.bash
# shellcheck disable=SC1091
source /ws/install/setup.bash
exec "$@"
