#!/usr/bin/env bash
# Issue 37's first ray-traced frame after opening a 10 M-triangle / 500-texture scene (rtlab bench --load's
# generated glTF, from the scene cache), on the lent GPU machine: fresh processes of
# `python -m app.bench_load trace SCENE TRACER` (load, then a Renderer's first AO frame at 640x360 read
# back: first_frame_s), a warm-up round first, then ROUNDS rounds per tracer, and one cProfile of the
# first frame (top cumulative entries) into $OUT.   TRACERS="cuda vulkan" ROUNDS=2 bash scripts/device_first_frame.sh
set -uo pipefail
OUT=${OUT:-out}; mkdir -p "$OUT"
if [ -f /tmp/rtlab-env.sh ]; then source /tmp/rtlab-env.sh; else source scripts/device_env.sh; fi
export RTLAB_SCENE_CACHE_DIR=/tmp/scache
S=$(python3 -c "
from pathlib import Path; from app.bench_load import generate
print(generate(Path('/tmp/lb/s10m'), 10_000_000, 500))")
# OLD=DIR (an older tree's app, core, rt, scenes and shaders, e.g. from git archive) alternates with this one
ROOT=$PWD
for t in ${TRACERS:-cuda vulkan}; do
  for round in $(seq 0 "${ROUNDS:-2}"); do
    for tree in this ${OLD:+old}; do
      dir=$ROOT; [ "$tree" = old ] && dir=$ROOT/$OLD
      r=$(cd "$dir" && PYTHONPATH=$dir:/tmp/site python3 -m app.bench_load trace "$S" "$t" 2>/dev/null | tail -1)
      [ "$round" = 0 ] || echo "$t $tree round $round: $r" | tee -a "$OUT/first_frame.txt"
    done
  done
done
t=${TRACERS%% *}; t=${t:-cuda}
python3 - "$S" "$t" <<'PY' > "$OUT/first_frame_profile.txt" 2>&1
# the first frame alone under cProfile (bench_load._child's steps after the load)
import cProfile, io, pstats, sys, time
from scenes.loaders import load_scene
scene = load_scene(sys.argv[1])
from app.camera import Camera
from app.gl_context import create_headless_context
from app.options import Options
from app.renderer import Renderer
opts = Options(); opts.apply([f"tracer={sys.argv[2]}", "accumulate=false"])
pr = cProfile.Profile(); t0 = time.perf_counter(); pr.enable()
r = Renderer(create_headless_context(), scene, opts, prefetch=True)
cam = Camera.from_view(scene.default_view(), scene.diagonal)
r.render(cam, 640, 360, "ao"); r.read_linear()
pr.disable(); print(f"first frame {time.perf_counter() - t0:.2f} s (profiled)")
s = io.StringIO(); pstats.Stats(pr, stream=s).sort_stats("cumulative").print_stats(45); print(s.getvalue())
PY
head -3 "$OUT/first_frame_profile.txt"
