#!/usr/bin/env bash
# Run the whole suite (./test.sh) on the ROS 2 path's Python package set, in a copy of this tree.
#
#   docker/test_ros_set.sh [DIR]     # default /tmp/phri-ros-set; writes DIR/ros-set.txt
#
# The set: Python 3.12 (Ubuntu 24.04's), the versions Ubuntu 24.04's apt gives for phri's rosdep
# keys where requirements-ros.txt does not replace them (APT_SET), then requirements-ros.txt, as
# the README's ROS 2 install and docker/Dockerfile install them. What this machine cannot install
# is stood in for: ROS 2 Kilted's rclpy and message packages by the ros-kilted-* wheels of
# requirements.txt, colcon by requirements-colcon.txt, ruff and mypy (./test.sh runs them) from
# PyPI. The exact list it ran on (pip freeze) goes to DIR/ros-set.txt.
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/.." && pwd)
DIR=${1:-/tmp/phri-ros-set}
PY=${PYTHON:-python3.12}
# Ubuntu 24.04 (noble) apt versions of the rosdep keys phri uses that requirements-ros.txt keeps:
# python3-numpy 1.26.4 (pinned there too), python3-yaml 6.0.1, python3-serial 3.5, python3-pil
# 10.2.0, python3-pytest 7.4.4 (Kilted's pytest).
APT_SET=(numpy==1.26.4 pyyaml==6.0.1 pyserial==3.5 pillow==10.2.0 pytest==7.4.4)
PACKAGES=(phri_common phri_description skin_driver contact_estimation wholebody_controller phri_sim phri_bringup phri_hardware)

"$PY" -c 'import sys; assert sys.version_info[:2] == (3, 12), sys.version' \
    || { echo "test_ros_set.sh: needs Python 3.12 (Ubuntu 24.04's); set PYTHON" >&2; exit 2; }
rm -rf "$DIR" && mkdir -p "$DIR"
git -C "$ROOT" ls-files -z --cached --others --exclude-standard \
    | (cd "$ROOT" && xargs -0 cp --parents -t "$DIR" 2>/dev/null || true)
cd "$DIR"
"$PY" -m venv .venv
PIP=(.venv/bin/python -m pip install --quiet --disable-pip-version-check)
"${PIP[@]}" --upgrade "pip>=24" "setuptools>=70,<80" wheel
grep -E '^ros-kilted-' requirements.txt > ros-wheels.txt
grep -E '^(ruff|mypy)' requirements.txt > dev-tools.txt
"${PIP[@]}" "${APT_SET[@]}" -r requirements-ros.txt -r ros-wheels.txt -r requirements-colcon.txt \
    -r dev-tools.txt
editable=()
for pkg in "${PACKAGES[@]}"; do editable+=(-e "./$pkg"); done
PYTHONWARNINGS=ignore "${PIP[@]}" --no-deps --no-build-isolation "${editable[@]}"
.venv/bin/python -m pip check
.venv/bin/python -m pip freeze --exclude-editable | grep -v -E '^(ros-|rosidl|rcl|rmw|rcutils)' \
    > ros-set.txt
.venv/bin/python -m phri_bringup.compile_kernels
echo "test_ros_set.sh: $(.venv/bin/python -V 2>&1), numpy $(.venv/bin/python -c \
    'import numpy; print(numpy.__version__)'); running ./test.sh in $DIR"
./test.sh
