#!/usr/bin/env bash
# Run the whole check suite: ruff, mypy, pytest. Expects ./setup.sh to have run.
set -euo pipefail
cd "$(dirname "$0")"
export ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST
export MUJOCO_GL=${MUJOCO_GL:-egl}
echo "== ruff"; .venv/bin/ruff check .
echo "== mypy"; .venv/bin/mypy
echo "== pytest"; .venv/bin/python -m pytest "$@"
