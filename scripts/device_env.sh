#!/usr/bin/env bash
# Sourced on the lent GPU machine: ../shared/tools/device-setup.sh (carried in .device-carry/), plus
# pyoidn, which is too big to travel with the rest in one call (10-minute calls, 64 MiB each): its
# repacked tar (pyoidn-cp312.tar.xz, no SYCL/HIP/Level Zero libraries: 48 MB) goes in two carried
# parts, .oidn-1/part and .oidn-2/part (its cffi and pycparser wheels in .oidn-3/), each kept in /tmp until both are there. The environment is
# saved to /tmp/rtlab-env.sh so that later calls on the same warm machine need carry nothing.
if [ -d .device-carry ] && [ ! -d /tmp/site/slangpy ]; then source .device-carry/device-setup.sh >/dev/null 2>&1; fi
# pyoidn's own dependencies (cffi, pycparser), flip-evaluator (the study's FLIP) and the viewer's glfw and
# imgui-bundle (scripts/viewer_fps.py), wheels carried in .oidn-3/ (15 MB)
[ -d .oidn-3 ] && python3 -m pip install -q --no-index --no-deps --no-compile --upgrade --target /tmp/site .oidn-3/*.whl
for i in 1 2; do [ -f .oidn-$i/part ] && cp .oidn-$i/part /tmp/oidn-part-$i; done
if [ -f /tmp/oidn-part-1 ] && [ -f /tmp/oidn-part-2 ] && [ ! -d /tmp/site/pyoidn ]; then
  cat /tmp/oidn-part-1 /tmp/oidn-part-2 | tar -xJf - -C /tmp/site
fi
export PYTHONPATH=/tmp/site:$PWD PYTHONUNBUFFERED=1
export VK_DRIVER_FILES=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
export __EGL_VENDOR_LIBRARY_FILENAMES=/usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json
export NUMBA_CACHE_DIR=${NUMBA_CACHE_DIR:-/tmp/numba-cache}
declare -px PYTHONPATH PYTHONUNBUFFERED VK_DRIVER_FILES __EGL_VENDOR_LIBRARY_FILENAMES NUMBA_CACHE_DIR \
  CUDA_PATH LD_LIBRARY_PATH 2>/dev/null > /tmp/rtlab-env.sh
true
