#!/usr/bin/env bash
# The whole suite on the lent GPU machine's Intel host with CI's software stack, CUDA hidden. Three calls
# in a row (the machine is given back after 30 s idle; pack.sh first, here):
#   run(carry=[".device-mesa"], command="tar -xJf .device-mesa/mesa.tar.xz -C / --skip-old-files && ldconfig")
#   run(carry=[".device-oidn"], command="mkdir -p /tmp/oidnsite && tar -xJf .device-oidn/oidn.tar.xz -C /tmp/oidnsite")
#   run(carry=[".device-carry", ".device-py"], command="JOBS=4 bash report/intel-suite/run.sh")
# JOBS: test workers (scripts/test.sh's 4 on that host); PYARGS: pytest's arguments (e.g. one file)
set -uo pipefail
OUT=${OUT:-out}; mkdir -p "$OUT"
source .device-carry/device-setup.sh >/dev/null 2>&1
tar -xJf .device-py/pysite.tar.xz -C /tmp/site
tar -xJf .device-py/xdo.tar.xz -C / --skip-old-files; ldconfig
export VK_DRIVER_FILES=/usr/share/vulkan/icd.d/lvp_icd.json
export __EGL_VENDOR_LIBRARY_FILENAMES=/usr/share/glvnd/egl_vendor.d/50_mesa.json
[ -d /tmp/oidnsite ] && export PYTHONPATH=$PYTHONPATH:/tmp/oidnsite
export CUDA_VISIBLE_DEVICES="" XDG_CACHE_HOME=/tmp/xdg CI=1
lscpu | grep -i "model name" > "$OUT/cpu.txt"
python3 - <<'PY' >> "$OUT/cpu.txt" 2>&1
import moderngl; c = moderngl.create_standalone_context(backend="egl"); print(c.info["GL_RENDERER"])
PY
t0=$(date +%s)
python3 -m app.cli warmup --software-gpu > "$OUT/warmup.log" 2>&1; echo "warmup rc $? $(( $(date +%s) - t0 )) s"
tail -3 "$OUT/warmup.log"
t1=$(date +%s)
timeout ${SUITE_S:-480} python3 -m pytest -q -n ${JOBS:-8} --durations=40 -p no:cacheprovider --junitxml="$OUT/junit.xml" ${PYARGS:-} > "$OUT/pytest.log" 2>&1
echo "pytest rc $? $(( $(date +%s) - t1 )) s"
tail -40 "$OUT/pytest.log"
cat "$OUT/cpu.txt"
