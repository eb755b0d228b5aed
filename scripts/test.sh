#!/usr/bin/env bash
# The test suite: headless GL through EGL, window tests under a private Xvfb.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
. scripts/python.sh
exec $PY -m pytest -q "$@"
