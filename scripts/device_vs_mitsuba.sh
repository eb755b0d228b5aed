#!/usr/bin/env bash
# Issue 36's yardstick on the lent GPU machine (the `device` tool): Mitsuba 3 `cuda_ad_rgb` and rtlab's
# shadows_one / gi_shadows frames on the same scenes, minutes apart, at 1920x1080.
# Mitsuba is not a dependency of rtlab: its wheel, cut to the cuda_ad_rgb and scalar_rgb variants and
# repacked with drjit's (.mitsuba/mitsuba-cut.tar.xz, 34 MB, made by hand from the PyPI wheels), travels
# in its own call: carry [".mitsuba"], after scripts/device_env.sh has set up the rest.
#   ROUNDS=2 SCENES=arcade,temple bash scripts/device_vs_mitsuba.sh    # into $OUT
# Rounds alternate Mitsuba and rtlab (CUDA, then Vulkan unless TRACERS says otherwise); MITSUBA_JSON=FILE
# compares with an earlier call's Mitsuba figures instead of measuring them again. OLD=DIR (an older tree's
# app, core, rt, scenes and shaders, e.g. from git archive, carried) alternates with this one: rows "cuda-old".
set -uo pipefail
OUT=${OUT:-out}; SCENES=${SCENES:-arcade,street,cafe,park,temple}; TRACERS=${TRACERS:-cuda vulkan}
mkdir -p "$OUT"
if [ -f /tmp/rtlab-env.sh ]; then source /tmp/rtlab-env.sh; else source scripts/device_env.sh; fi
if [ -f .mitsuba/mitsuba-cut.tar.xz ] && [ ! -d /tmp/site/mitsuba ]; then
  tar -xJf .mitsuba/mitsuba-cut.tar.xz -C /tmp/site
fi
for round in $(seq 1 "${ROUNDS:-1}"); do
  if [ -n "${MITSUBA_JSON:-}" ]; then  # Mitsuba measured by an earlier call: compare with that
    cp "$MITSUBA_JSON" "$OUT/mitsuba_$round.json"
  else
    python3 report/mitsuba_frames.py --variant cuda_ad_rgb --size 1920x1080 --frames "${FRAMES:-30}" \
        --scenes "$SCENES" --out "$OUT/mitsuba_$round.json" > "$OUT/mitsuba_$round.log" 2>&1 \
        || tail -5 "$OUT/mitsuba_$round.log"
  fi
  for t in $TRACERS; do
    for tree in this ${OLD:+old}; do
      dir=$PWD; name=$t; [ "$tree" = old ] && dir=$PWD/$OLD && name=$t-old
      (cd "$dir" && PYTHONPATH=$dir:/tmp/site python3 -m app.cli bench --scenes "$SCENES" \
        --configs shadows_one,gi_shadows --set "tracer=$t" --size 1920x1080 --seconds "${SECONDS_PER_CONFIG:-2}" \
        --no-quality --path-frames 0 --out "/tmp/vs_mitsuba_$name") > "$OUT/${name}_$round.log" 2>&1 \
        || tail -5 "$OUT/${name}_$round.log"
      cp "/tmp/vs_mitsuba_$name/results.json" "$OUT/results_${name}_$round.json"
    done
  done
done
python3 - "$OUT" <<'PY' | tee "$OUT/table.txt"
# each round: Mitsuba's mean frame (ms), rtlab's, and Mitsuba / rtlab (issue 36's target: >= 1.5)
import json, sys
from pathlib import Path
out = Path(sys.argv[1])
pairs = {"shadows_one": "direct", "gi_shadows": "one_bounce"}
for m in sorted(out.glob("mitsuba_*.json")):
    r = m.stem.split("_")[1]
    mi = {(x["scene"], x["integrator"]): x["frame_ms_mean"] for x in json.loads(m.read_text())["rows"]}
    for res in sorted(out.glob(f"results_*_{r}.json")):
        t = res.stem.split("_")[1]
        for x in json.loads(res.read_text())["results"]:
            ref = mi.get((x["scene"], pairs.get(x["config"], "")))
            if ref:
                ms = x["frame_ms"]["mean"]
                print(f"round {r} {t:10s} {x['scene']:7s} {x['config']:11s} rtlab {ms:6.2f} ms"
                      f"  mitsuba {ref:6.2f} ms  {ref / ms:4.2f}x  gpu {x.get('gpu_ms', 0):5.2f} ms")
PY
