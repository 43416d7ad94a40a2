#!/usr/bin/env bash
# The suite on the image's plain colcon build, as ./test.sh runs it on the pip path: ruff, mypy,
# colcon test (every package's pytest suite, the launch tests included), colcon lint, then the
# summary that fails a package which ran 0 tests (its last line: "N passed, N failed, N skipped").
# Run inside the image (docker/Dockerfile's test stage, compose's test service).
set -eo pipefail
WS=${WS:-/ws}
# shellcheck disable=SC1090,SC1091
source "/opt/ros/${ROS_DISTRO:?}/setup.bash"
# shellcheck disable=SC1091
source "$WS/install/setup.bash"
set -u
cd "$WS/src/phri"
echo "== ruff"; ruff check .
echo "== mypy"; mypy
cd "$WS"
echo "== colcon test"
rm -f build/*/pytest.xml
status=0
colcon test --base-paths src/phri --event-handlers console_cohesion+ \
    --return-code-on-test-failure || status=$?
colcon test-result --verbose || status=1
echo "== colcon lint"
colcon lint --base-paths src/phri || status=1
echo "== test results"
mapfile -t packages < <(colcon list --base-paths src/phri --names-only)
python3 -m phri_common.junit_summary build "${packages[@]}" || status=1
exit "$status"
