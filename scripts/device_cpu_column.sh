#!/usr/bin/env bash
# The study's CPU column on the lent machine: Embree on its host cores, every base configuration at
# 1920x1080, timing only (quality comes from the GPU study: same images up to noise). Into $OUT.
set -uo pipefail
OUT=${OUT:-out}
if [ -f /tmp/rtlab-env.sh ]; then source /tmp/rtlab-env.sh; else source scripts/device_env.sh; fi
timeout "${LIMIT:-450}" python3 -m app.cli bench --set tracer=embree --size 1920x1080 --no-quality \
  --seconds "${SECONDS_PER_CONFIG:-2}" --configs "${CONFIGS:-forward,reflections,shadows_all,shadows_one,gi_1,gi_4,gi_shadows,ao_1,ao_4,hybrid,hybrid_gi}" \
  --out /tmp/cpu-column > "$OUT/cpu_column.log" 2>&1
echo "bench exit $?" >> "$OUT/cpu_column.log"
cp /tmp/cpu-column/results.json "$OUT/cpu_results.json" 2>/dev/null
cp /tmp/cpu-column/report.md "$OUT/cpu_report.md" 2>/dev/null
