#!/usr/bin/env bash
# reflections with the environment sample (this tree) against bf0430a's shaders, alternated; then
# a cProfile of the first AO frame after a 10 M-triangle load on CUDA
set -uo pipefail
source .device-carry/device-setup.sh >/dev/null 2>&1
export PYTHONPATH=${PYTHONPATH:-}:$PWD NUMBA_CACHE_DIR=/tmp/numba-cache RTLAB_SCENE_CACHE_DIR=/tmp/scache
echo "rev $(cat .device-run/rev)"; nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p /tmp/new_shaders && cp shaders/rt/{reflections,paths,brdf}.slang /tmp/new_shaders/
for t in cuda vulkan; do
  for tree in new old; do
    if [ $tree = new ]; then cp /tmp/new_shaders/*.slang shaders/rt/; else cp .device-run/old_shaders/*.slang shaders/rt/; fi
    timeout 200 python3 -m app.cli bench --scenes arcade,street,cafe,park,temple --set tracer=$t --size 1920x1080 --seconds 1.5 \
      --no-quality --path-frames 0 --configs reflections --out $OUT/refl_${t}_$tree > /tmp/b.log 2>&1 || { echo "bench $t $tree failed"; tail -5 /tmp/b.log; }
    python3 - "$t" "$tree" <<'PY'
import json, sys, os
t, tree = sys.argv[1:]
rows = json.load(open(f"{os.environ['OUT']}/refl_{t}_{tree}/results.json"))["results"]
for row in rows:
    print(f"{t:6} {tree} {row.get('scene','?'):7} {row['config']:12} frame {row['frame_ms']['mean']:6.2f} gpu {row['gpu_ms']:6.2f} host {row['host_overhead_ms']:5.2f}")
PY
  done
done
cp /tmp/new_shaders/*.slang shaders/rt/
python3 -c "
from pathlib import Path; from app.bench_load import generate
print(generate(Path('/tmp/lb/s10m'), 10_000_000, 500))"
S=$(ls /tmp/lb/s10m/*.gltf | head -1)
for i in 1 2; do python3 -m app.bench_load trace $S cuda 2>/dev/null | tail -1; done
python3 -m cProfile -o $OUT/ff.prof -m app.bench_load trace $S cuda 2>/dev/null | tail -1
python3 - <<'PY'
import pstats, os
p = pstats.Stats(os.environ["OUT"] + "/ff.prof"); p.sort_stats("cumulative").print_stats(45)
PY
