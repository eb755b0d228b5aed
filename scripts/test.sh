#!/usr/bin/env bash
# The test suite: headless GL through EGL, window tests under a private Xvfb.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
. scripts/python.sh
# every kernel compiled once, in parallel processes, before the tests that use them
$PY -c "import sys; from rt.backends import kernels_ready; sys.exit(0 if kernels_ready() else 1)" \
    || $PY -m app.cli warmup
# one test worker per core, at most 4 (each also runs threads of its own)
jobs=$(nproc 2>/dev/null || echo 1); [ "$jobs" -gt 4 ] && jobs=4
exec $PY -m pytest -q -n "${RTLAB_TEST_JOBS:-$jobs}" "$@"
