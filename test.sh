#!/usr/bin/env bash
# Run the whole check suite: ruff, mypy, then the ROS 2 way: `colcon build` of every package and
# `colcon test`, which runs each package's pytest suite in its own directory (the one pytest run
# of the suite), a summary that fails any package that ran 0 tests, and `colcon lint` where a
# ROS install provides what it needs. Expects ./setup.sh.
#
#   ./test.sh                 # everything (what CI runs)
#   ./test.sh PYTEST_ARGS...  # ruff, mypy, then pytest from the repository root with these args
set -euo pipefail
cd "$(dirname "$0")"
export ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST
export MUJOCO_GL=${MUJOCO_GL:-egl}
export PATH="$PWD/.venv/bin:$PATH"
echo "== ruff"; ruff check .
echo "== mypy"; mypy
if [ "$#" -gt 0 ]; then
    echo "== pytest"; exec python -m pytest "$@"
fi
mapfile -t PACKAGES < <(for f in */package.xml; do dirname "$f"; done)
# A plain (copying) build, as users and the Docker image build: the tests then import the
# installed copies and find their data in install/<pkg>/share, which --symlink-install would hide.
echo "== colcon build (${#PACKAGES[@]} packages)"
colcon build --event-handlers console_cohesion- summary+
# The installed copies are new files to numba's cache: compile their kernels once here, not in
# several test processes at a time.
echo "== numba kernels of the installed packages"
(
    set +u  # colcon's setup scripts read unset variables
    # shellcheck disable=SC1091
    . install/local_setup.sh
    python -m phri_bringup.compile_kernels
)
echo "== colcon test"
rm -f build/*/pytest.xml
colcon_rc=0
colcon test --event-handlers console_cohesion+ summary+ --return-code-on-test-failure \
    || colcon_rc=$?
# colcon lint needs launch, launch_ros and a rosdep database, which only a ROS install has (no
# wheels exist); test_packaging.py (run above) makes the same import/package.xml check anyway.
lint_rc=0
if python -c "import colcon_lint.verb.lint_depends" >/dev/null 2>&1 \
        && rosdep resolve rclpy >/dev/null 2>&1; then
    echo "== colcon lint"; colcon lint || lint_rc=$?
else
    echo "== colcon lint: skipped (needs launch, launch_ros and rosdep's database: a ROS install)"
fi
echo "== test results"  # last, so the closing line is the suite's "N passed, N failed, N skipped"
summary_rc=0
python -m phri_common.junit_summary build "${PACKAGES[@]}" || summary_rc=$?
for rc in "$colcon_rc" "$lint_rc" "$summary_rc"; do
    if [ "$rc" -ne 0 ]; then exit "$rc"; fi
done
