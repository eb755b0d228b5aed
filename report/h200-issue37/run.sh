#!/usr/bin/env bash
# issue 37 (this session): the map's importance sampling (reference) and the shadows pass's environment
# sample on the H200: CUDA and Vulkan against Embree on the same random numbers, and the shadows pass's
# cost, this tree against .old (70ebca6, the session's start), alternated in one run
set -uo pipefail
OUT=${OUT:-out}; mkdir -p "$OUT"
source .device-carry/device-setup.sh >/dev/null 2>&1
python3 -m pip install -q --no-index --no-deps --target /tmp/exrsite .device-py/exr/*.whl 2>&1 | tail -1
export PYTHONPATH=$PYTHONPATH:/tmp/exrsite NUMBA_CACHE_DIR=/tmp/numba-cache
python3 - <<'PY'
import numpy as np, OpenEXR
h, w = 256, 512
y = np.cos((np.arange(h) + .5) / h * np.pi)[:, None, None]
sky = np.where(y >= 0, (1 - np.sqrt(np.clip(y, 0, 1))) * np.array([1.0, .9, .8]) + np.sqrt(np.clip(y, 0, 1)) * np.array([.35, .5, .9]), .25)
img = np.broadcast_to(sky, (h, w, 3)).astype(np.float32).copy()
c, r = int(.375 * w), int(.252 * h)
img[r - 1:r + 2, c - 1:c + 2] = (3000, 2800, 2500)
OpenEXR.File({"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}, {"RGB": img}).write("/tmp/sun.exr")
PY
S=.device-run/suzanne/Suzanne.gltf
for p in reference shadows; do
  for t in embree cuda vulkan; do
    python3 -m app.cli shot $S --pass $p --size 320x180 --frames 64 --set tracer=$t --set env=/tmp/sun.exr \
      --raw /tmp/${p}_$t.npy --out $OUT/suzanne_${p}_$t.png 2>&1 | tail -1
  done
  python3 -c "
import numpy as np
a, b, c = (np.load(f'/tmp/${p}_{t}.npy') for t in ('embree', 'cuda', 'vulkan'))
print('$p means embree/cuda/vulkan', a.mean(), b.mean(), c.mean(), 'max |cuda-embree|', abs(b-a).max(), 'median', np.median(abs(b-a)))"
done
for t in cuda vulkan; do
  for which in new old new old; do
    dir=$PWD; [ $which = old ] && dir=$PWD/.old
    (cd $dir && PYTHONPATH=/tmp/site:/tmp/exrsite:$dir python3 -m app.cli bench --set tracer=$t --size 1920x1080 --seconds 1 \
       --no-quality --configs shadows_one,shadows_all --scenes street,park,arcade --out /tmp/b_${t}_$which > /dev/null 2>>/tmp/err.log)
    python3 - /tmp/b_${t}_$which/results.json $t $which <<'PY'
import json, sys
for r in json.load(open(sys.argv[1]))["results"]:
    if r["config"] != "forward":
        print(sys.argv[2], sys.argv[3], r["scene"], r["config"], "frame", round(r["frame_ms"]["mean"], 2), "gpu", round(r.get("gpu_ms", 0), 2))
PY
  done
done
tail -3 /tmp/err.log
