#!/usr/bin/env bash
# The Python the tests run the peers of bench/peers/ with (tests/common peer_python):
# a venv at target/peer-venv (or $1) with the pinned NumPy, OpenCV (headless) and skylibs (with
# SciPy, for tests/skylibs_cube.rs) from PyPI.
#   bash scripts/peer-venv.sh            # then `cargo test --release` finds it
set -euo pipefail
cd "$(dirname "$0")/.."
venv="${1:-target/peer-venv}"
if [ ! -x "$venv/bin/python" ]; then
    python3 -m venv "$venv"
fi
"$venv/bin/pip" install --quiet --disable-pip-version-check -r bench/peers/requirements.txt
"$venv/bin/python" -c 'import numpy, cv2, envmap; from importlib.metadata import version; print("peer venv:", "numpy", numpy.__version__, "opencv", cv2.__version__, "skylibs", version("skylibs"))'
