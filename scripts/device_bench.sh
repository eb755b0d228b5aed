#!/usr/bin/env bash
# The GPU backend's figures on the lent H200 (the `device` tool; see ../shared/GPU.md):
#   bash ../shared/tools/device-pack.sh, then run this there with carry=[".device-carry"].
# Writes bench results for tracer=vulkan and tracer=cuda at 1920x1080, and scene upload + BVH
# build times of park:5, into $OUT (default ./out).
set -euo pipefail
OUT=${OUT:-out}
source .device-carry/device-setup.sh >/dev/null 2>&1
export NUMBA_CACHE_DIR=${NUMBA_CACHE_DIR:-/tmp/numba-cache}
python3 -m app.cli devices | tee "$OUT/devices.txt"
for t in vulkan cuda; do
  python3 -m app.cli bench --set tracer=$t --size 1920x1080 --seconds ${SECONDS_PER_CONFIG:-3} --no-quality \
      --configs forward,ao_1,shadows_one,reflections,gi_1,gi_shadows --out "/tmp/bench_$t" > "$OUT/bench_$t.log" 2>&1
  cp "/tmp/bench_$t/results.json" "$OUT/results_$t.json"
  cp "/tmp/bench_$t/report.md" "$OUT/report_$t.md"
done
python3 - <<'PY' | tee "$OUT/upload.txt"
import time
from rt.backends import create
from scenes.loaders import load_scene
scene = load_scene("park:5")
for kind in ("vulkan", "cuda"):
    backend = create(kind)
    for attempt in range(2):  # the first also opens the device and loads the driver
        t0 = time.perf_counter()
        backend.set_scene(scene)
        print(f"{kind}: park:5 ({len(scene.indices):,} triangles) upload + BVH build {time.perf_counter() - t0:.3f} s"
              f" (attempt {attempt + 1})")
PY
