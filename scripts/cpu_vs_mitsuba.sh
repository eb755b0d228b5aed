#!/usr/bin/env bash
# Issue 43's yardstick on this machine's CPU: rtlab's Embree frames (`bench`, shadows_one and
# gi_shadows, the raster G-buffer included) against Mitsuba 3's llvm_ad_rgb at 1 spp (direct, and
# path max_depth 3: report/mitsuba_frames.py), alternated ROUNDS times, one table per round:
#   [GBUFFER=rt] bash scripts/cpu_vs_mitsuba.sh OUT_DIR [SIZE] [ROUNDS]     (default raster, 512x512, 2)
# Mitsuba is not an rtlab dependency: `pip install mitsuba` first. Its LLVM backend needs libLLVM;
# Debian's LLVM 15 miscompiles its kernels on AVX-512 CPUs ("Cannot select"), LLVM 19 works
# (apt-get install libllvm19; DRJIT_LIBLLVM_PATH is set here when that library is present).
set -euo pipefail
OUT=${1:?usage: bash scripts/cpu_vs_mitsuba.sh OUT_DIR [SIZE] [ROUNDS]}; SIZE=${2:-512x512}; ROUNDS=${3:-2}
cd "$(dirname "$0")/.."
mkdir -p "$OUT"
LLVM19=/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1
if [ -z "${DRJIT_LIBLLVM_PATH:-}" ] && [ -f "$LLVM19" ]; then export DRJIT_LIBLLVM_PATH=$LLVM19; fi
for r in $(seq 1 "$ROUNDS"); do
  python3 report/mitsuba_frames.py --variant llvm_ad_rgb --size "$SIZE" --frames 10 --out "$OUT/mitsuba_$r.json" \
    > "$OUT/mitsuba_$r.log" 2>&1
  python3 -m app.cli bench --configs shadows_one,gi_shadows --size "$SIZE" --no-quality --seconds 2 \
    --set tracer=embree --set "gbuffer=${GBUFFER:-raster}" --out "$OUT/rtlab_$r" > "$OUT/rtlab_$r.log" 2>&1
done
python3 - "$OUT" "$ROUNDS" <<'PY'
import json
import sys
out, rounds = sys.argv[1], int(sys.argv[2])
pairs = {"shadows_one": "direct", "gi_shadows": "one_bounce"}
print("| round | scene | rtlab shadows_one ms (G-buffer) | Mitsuba direct ms | ratio "
      "| rtlab gi_shadows ms (G-buffer) | Mitsuba one bounce ms | ratio |")
print("| --- | --- | --- | --- | --- | --- | --- | --- |")
for r in range(1, rounds + 1):
    mi = {(m["scene"], m["integrator"]): m["frame_ms_median"] for m in json.load(open(f"{out}/mitsuba_{r}.json"))["rows"]}
    runs = {(x["scene"], x["config"]): x for x in json.load(open(f"{out}/rtlab_{r}/results.json"))["results"]}
    for scene in dict.fromkeys(s for s, _ in mi):
        cells = []
        for config, integ in pairs.items():
            x, m = runs[(scene, config)], mi[(scene, integ)]
            ms = x["frame_ms"]["median"]
            cells += [f"{ms:.1f} ({x['split_ms']['G-buffer']:.1f})", f"{m:.1f}", f"{ms / m:.2f}"]
        print(f"| {r} | {scene} | " + " | ".join(cells) + " |")
PY
