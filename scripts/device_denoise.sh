#!/usr/bin/env bash
# Issue 38's denoisers on the lent GPU machine (the `device` tool): OIDN's GPU device checked against
# its CPU filter on CUDA and Vulkan, then the bench's Denoisers section at 1920x1080 on the GPU.
# The carry takes three calls on one warm machine (scripts/device_env.sh): [".device-carry", ".oidn-3"],
# then [".oidn-1"], then [".oidn-2"]; each call begins `source scripts/device_env.sh;`.
#   bash scripts/device_denoise.sh tests             # tests/test_oidn_device.py on cuda and vulkan
#   bash scripts/device_denoise.sh bench SCENES T    # bench of gi_1/ao_1 + svgf/oidn, tracer=T, into $OUT/T_*
#   bash scripts/device_denoise.sh split             # SVGF's cost at 1080p on a glossy glTF, svgf.split on and off
set -uo pipefail
OUT=${OUT:-out}
mkdir -p "$OUT"
case "${1:-}" in
tests)
  nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee "$OUT/gpu.txt"
  python3 -m app.cli devices | tee "$OUT/devices.txt"
  for t in cuda vulkan; do
    RTLAB_TEST_GPU_TRACER=$t python3 -m pytest -q -x -p no:cacheprovider tests/test_oidn_device.py \
        tests/test_svgf_device.py 2>&1 | tail -15 | tee "$OUT/tests_$t.txt"
  done
  ;;
bench)
  scenes=${2:-arcade,street,cafe,park,temple}; t=${3:-cuda}
  python3 -m app.cli bench --scenes "$scenes" --configs gi_1+svgf,gi_1+oidn,ao_1+svgf,ao_1+oidn \
      --size 1920x1080 --quality-size 1920x1080 --seconds "${SECONDS_PER_CONFIG:-2}" --path-frames 0 \
      --set "tracer=$t" --out "/tmp/bench_${t}_$scenes" 2>&1 | tail -40 | tee "$OUT/${t}_${scenes//,/_}.log"
  cp "/tmp/bench_${t}_$scenes/results.json" "$OUT/${t}_${scenes//,/_}_results.json"
  cp "/tmp/bench_${t}_$scenes/report.md" "$OUT/${t}_${scenes//,/_}_report.md"
  ;;
split)
  # the glossy checker of tests/test_denoise.py (glTF's BRDF: the specular part filtered apart, or not)
  python3 -c "import json; from tests.gltf_writer import checker_glossy_document as d
open('/tmp/checker.gltf', 'w').write(json.dumps(d()))"
  for round in $(seq 1 "${ROUNDS:-2}"); do
    for t in ${TRACERS:-cuda vulkan}; do
      for split in true false; do
        python3 -m app.cli bench --scenes /tmp/checker.gltf --configs gi_1+svgf --size "${SIZE:-1920x1080}" --no-quality \
            --seconds "${SECONDS_PER_CONFIG:-2}" --path-frames 0 --set "tracer=$t" --set "svgf.split=$split" \
            --out "/tmp/split_${t}_$split" > /dev/null 2>&1 || echo "bench $t split=$split failed"
        python3 - "/tmp/split_${t}_$split/results.json" "$t" "$split" "$round" <<'PY' | tee -a "$OUT/split.txt"
import json, sys
r = [x for x in json.load(open(sys.argv[1]))["results"] if x["config"] == "gi_1+svgf"][0]
p = r["passes_ms"]
print(f"round {sys.argv[4]} {sys.argv[2]:6s} svgf.split={sys.argv[3]:5s} frame {r['frame_ms']['mean']:6.2f} ms  "
      f"gi_gpu {p.get('gi_gpu', 0):5.2f}  svgf_gpu {p.get('svgf_gpu', 0):5.2f} ms")
PY
      done
    done
  done
  ;;
*)
  echo "usage: bash scripts/device_denoise.sh tests | bench SCENES TRACER | split" >&2; exit 2
  ;;
esac
