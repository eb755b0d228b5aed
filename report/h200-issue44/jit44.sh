#!/usr/bin/env bash
# Issue 44 on the lent machine's 16-core host: numba kernels compiled as linked inner code (this
# tree, `new`) against the tree before (`old`: rt/embree/jit.py and reflections.py of the commit
# before), alternated. Step `cold`: each pass's first frame in a fresh process with an empty kernel
# cache, and a cold `rtlab warmup`; step `frames`: Embree frames at 1280x720 (bench, warm caches).
set -uo pipefail
source .device-carry/device-setup.sh >/dev/null 2>&1
export PYTHONPATH=${PYTHONPATH:-}:$PWD
echo "rev $(cat .device-run/rev) $(lscpu | grep 'Model name' | sed 's/  */ /g')"
use() {  # use new|old
  if [ "$1" = new ]; then cp .device-run/new_embree/*.py rt/embree/; else
    cp .device-run/old_embree/*.py rt/embree/; rm -f rt/embree/inner_code.py; fi
}
step=${1:-cold}
if [ "$step" = cold ]; then
  for round in ${ROUNDS:-1 2}; do for tree in new old; do
    use $tree
    for p in ${PASSES:-gi reflections shadows}; do
      t0=$EPOCHREALTIME
      NUMBA_CACHE_DIR=/tmp/nc_${EPOCHSECONDS}_${tree}_${round}_$p timeout 150 python3 -m app.cli shot cafe --pass $p --set tracer=embree --size 32x18 --out /tmp/x.png >/dev/null 2>&1
      echo "cold $tree round $round $p $(awk "BEGIN{printf \"%.1f\", $EPOCHREALTIME - $t0}") s"
    done
  done; done
  for tree in new old; do
    use $tree
    t0=$EPOCHREALTIME
    NUMBA_CACHE_DIR=/tmp/nw_${EPOCHSECONDS}_$tree python3 -m app.cli warmup 2>&1 | tail -1
    echo "warmup $tree $(awk "BEGIN{printf \"%.1f\", $EPOCHREALTIME - $t0}") s"
  done
else
  for tree in new old; do use $tree; NUMBA_CACHE_DIR=/tmp/nf_$tree python3 -m app.cli warmup >/dev/null 2>&1; done
  for round in 1 2; do for tree in new old; do
    use $tree
    NUMBA_CACHE_DIR=/tmp/nf_$tree timeout 250 python3 -m app.cli bench --scenes ${SCENES:-arcade,cafe,temple} --size 1280x720 \
      --seconds 1.5 --no-quality --path-frames 0 --set tracer=embree --configs ${CONFIGS:-shadows_one,gi_shadows,reflections,ao_1,gi_1} \
      --out /tmp/bench_${tree}_$round > /tmp/b.log 2>&1 || { echo "bench $tree failed"; tail -3 /tmp/b.log; }
    python3 - "$tree" "$round" <<'PY'
import json, sys
tree, rnd = sys.argv[1:]
for row in json.load(open(f"/tmp/bench_{tree}_{rnd}/results.json"))["results"]:
    print(f"frames {tree} round {rnd} {row.get('scene', '?'):7} {row['config']:12} median {row['frame_ms']['median']:7.2f} ms")
PY
  done; done
fi
use new
