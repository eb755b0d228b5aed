#!/usr/bin/env bash
# first ray-traced (AO) frame after opening a 10 M-triangle / 500-texture scene, in fresh
# processes: this tree against .old2 (7341936, the session's start), alternated
set -uo pipefail
source .device-carry/device-setup.sh >/dev/null 2>&1
export NUMBA_CACHE_DIR=/tmp/numba-cache RTLAB_SCENE_CACHE_DIR=/tmp/scache
ROOT=$PWD
python3 -c "
from pathlib import Path; from app.bench_load import generate
print(generate(Path('/tmp/lb/s10m'), 10_000_000, 500))"
S=$(ls /tmp/lb/s10m/*.gltf | head -1)
for t in cuda vulkan; do
  for round in 0 1 2; do
    for tree in new old; do
      if [ $tree = new ]; then cd $ROOT; else cd $ROOT/.old2; fi
      r=$(PYTHONPATH=${PYTHONPATH:-}:$PWD python3 -m app.bench_load trace $S $t 2>/dev/null | tail -1)
      [ $round = 0 ] || echo "$t $tree $r"
    done
  done
done
