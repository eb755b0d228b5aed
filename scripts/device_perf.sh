#!/usr/bin/env bash
# The GPU backend's efficiency on the lent H200 (pass GPU time vs the same device tracing the
# pass's own rays alone), 1920x1080, both device kinds, into $OUT (default ./out).
set -euo pipefail
OUT=${OUT:-out}
source .device-carry/device-setup.sh >/dev/null 2>&1
export NUMBA_CACHE_DIR=${NUMBA_CACHE_DIR:-/tmp/numba-cache}
for t in cuda vulkan; do
  python3 -m app.cli bench --perf --set tracer=$t --perf-sizes 1920x1080 --frames 3 --out "/tmp/perf_$t" \
      > "$OUT/perf_$t.log" 2>&1
  cp "/tmp/perf_$t/perf.json" "$OUT/perf_$t.json"
done
