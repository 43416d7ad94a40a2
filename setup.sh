#!/usr/bin/env bash
# Create .venv and install everything phri needs: ROS 2 Kilted wheels, numeric and QP libraries,
# and every workspace package in editable mode. Idempotent: a second run with unchanged
# requirements and package metadata returns in well under a second.
set -euo pipefail
cd "$(dirname "$0")"

PACKAGES=(phri_common phri_description skin_driver contact_estimation wholebody_controller phri_sim phri_bringup phri_hardware)

pick_python() {
    for candidate in "${PYTHON:-}" python3.11 python3; do
        if [ -n "$candidate" ] && command -v "$candidate" >/dev/null 2>&1; then
            if "$candidate" -c 'import sys; sys.exit(0 if sys.version_info[:2] == (3, 11) else 1)'; then
                echo "$candidate"; return 0
            fi
        fi
    done
    echo "setup.sh: Python 3.11 is required (the ROS 2 Kilted wheels are built for it); set PYTHON=/path/to/python3.11" >&2
    return 1
}

stamp_of_inputs() {
    cat setup.sh requirements.txt requirements-colcon.txt "${PACKAGES[@]/%//setup.cfg}" "${PACKAGES[@]/%//package.xml}" | sha256sum | cut -d' ' -f1
}

STAMP_FILE=.venv/.phri-setup-stamp
if [ -f "$STAMP_FILE" ] && [ "$(cat "$STAMP_FILE")" = "$(stamp_of_inputs)" ] && [ -x .venv/bin/python ]; then
    echo "setup.sh: .venv is up to date"
    exit 0
fi

PY=$(pick_python)
if [ ! -x .venv/bin/python ]; then
    echo "setup.sh: creating .venv with $PY"
    "$PY" -m venv .venv
fi
echo "setup.sh: installing dependencies (first run takes about a minute)"
.venv/bin/python -m pip install --quiet --disable-pip-version-check --upgrade "pip>=24" "setuptools>=70,<80" wheel  # colcon-core needs setuptools < 80
.venv/bin/python -m pip install --quiet --disable-pip-version-check -r requirements.txt \
    -r requirements-colcon.txt
editable=()
for pkg in "${PACKAGES[@]}"; do editable+=(-e "./$pkg"); done
PYTHONWARNINGS=ignore .venv/bin/python -m pip install --quiet --disable-pip-version-check --no-deps \
    --no-build-isolation "${editable[@]}"
echo "setup.sh: compiling the numba kernels (first run about a minute, then cached)"
.venv/bin/python -m phri_bringup.compile_kernels
stamp_of_inputs > "$STAMP_FILE"
echo "setup.sh: done; commands are in .venv/bin (phri, skin_driver_node, contact_estimation_node, ...)"
