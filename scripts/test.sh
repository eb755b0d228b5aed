#!/usr/bin/env bash
# The test suite: headless GL through EGL, window tests under a private Xvfb.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
. scripts/python.sh
# the cluster extra (Ray): its tests run a local Ray cluster (tests/test_cluster.py)
$PY -c "import ray" 2>/dev/null || $PY -m pip install -q --disable-pip-version-check -e '.[dev,cluster]'
# every kernel and software Vulkan pipeline compiled once, in parallel processes, before the
# tests that use them (what this version has compiled already is left out)
$PY -m app.cli warmup --software-gpu
# one test worker per core, at most 4 (each also runs threads of its own)
jobs=$(nproc 2>/dev/null || echo 1); [ "$jobs" -gt 4 ] && jobs=4
exec $PY -m pytest -q -n "${RTLAB_TEST_JOBS:-$jobs}" "$@"
