#!/usr/bin/env bash
set -uo pipefail
OUT=${OUT:-out}; mkdir -p "$OUT"
source .device-carry/device-setup.sh >/dev/null 2>&1
export NUMBA_CACHE_DIR=/tmp/numba-cache
python3 -m app.cli warmup > /dev/null 2>&1
python3 -m app.cli bench --load --out /tmp/lb 2>&1 | tail -8
cp /tmp/lb/load.json $OUT/
