#!/usr/bin/env bash
# Run HERE (a Debian 12 machine set up by scripts/setup.sh), in the project's root, before running the
# whole suite on the lent GPU machine's Intel host with CI's own software stack (Mesa 25.0.7 llvmpipe
# GL and lavapipe Vulkan, Xvfb, xdotool, the dev extra, pyoidn): that image has none of them, and one
# call carries at most 64 MiB with the tree, so they travel in three calls (see run.sh).
set -euo pipefail
cd "$(git rev-parse --show-toplevel)"
for d in .device-mesa .device-py .device-oidn; do mkdir -p $d; grep -qx "/$d/" .git/info/exclude || echo "/$d/" >> .git/info/exclude; done
L=usr/lib/x86_64-linux-gnu
# Mesa and its libraries that Ubuntu 24.04 lacks (extracted there with --skip-old-files: its own win)
(cd / && tar -cf - $(ls -d $L/libEGL_mesa.so.0* $L/libGLX_mesa.so.0* $L/libvulkan_lvp.so $L/libgallium-*.so \
   $L/libglapi.so.0* $L/libgbm.so.1* $L/gbm $L/dri $L/libLLVM-15.so.1 $L/libz3.so.4* $L/libsensors.so.5* \
   $L/libwayland-client.so.0* $L/libwayland-server.so.0* $L/libxshmfence.so.1* $L/libXxf86vm.so.1* \
   $L/libxcb-{dri3,present,randr,sync,xfixes,glx,shm}.so.* $L/libX11-xcb.so.1* $L/libdrm_{amdgpu,intel}.so.1* \
   $L/libXfont2.so.2* $L/libfontenc.so.1* $L/libpixman-1.so.0* $L/libunwind.so.8* $L/libaudit.so.1* \
   $L/libcap-ng.so.0* $L/libxkbfile.so.1* usr/bin/Xvfb usr/bin/xkbcomp usr/share/X11/xkb \
   usr/share/vulkan/icd.d/lvp_icd.json usr/share/glvnd/egl_vendor.d/50_mesa.json) | xz -T0 -9 > .device-mesa/mesa.tar.xz)
(cd / && tar -cJf "$OLDPWD/.device-py/xdo.tar.xz" usr/bin/xdotool $(ls -d $L/libxdo.so.3* $L/libXtst.so.6* \
   $L/libXinerama.so.1* $L/libxkbcommon.so.0* $L/libfreetype.so.6* $L/libpng16.so.16* $L/libbrotli{dec,common}.so.1*))
# the dev extra and the viewer's packages for the host's Python 3.12 (imgui-bundle without its demos)
t=$(mktemp -d)
P=(--only-binary=:all: --python-version 3.12 --implementation cp --platform manylinux_2_28_x86_64
   --platform manylinux_2_17_x86_64 --platform manylinux2014_x86_64 --platform any)
python3 -m pip download -q --no-deps "${P[@]}" -d "$t/w" pytest pytest-xdist execnet hypothesis glfw imgui-bundle \
  iniconfig pluggy sortedcontainers attrs flip-evaluator cffi pycparser
python3 -m pip install -q --no-deps --no-compile "${P[@]}" --target "$t/site" "$t"/w/*.whl
rm -rf "$t"/site/imgui_bundle/demos_* "$t/site/bin"; find "$t/site" -name '*.pyi' -delete
tar -C "$t/site" -cf - . | xz -T0 -6 > .device-py/pysite.tar.xz
# pyoidn: its CPU device only (47 MB, mostly the network weights)
S=$(python3 -c "import pyoidn, os; print(os.path.dirname(os.path.dirname(pyoidn.__file__)))")
(cd "$S" && tar -cf - pyoidn/*.py pyoidn/oidn/lib/libOpenImageDenoise.so* pyoidn/oidn/lib/libOpenImageDenoise_core.so.* \
   pyoidn/oidn/lib/libOpenImageDenoise_device_cpu.so.* pyoidn/oidn/lib/libtbb.so* pyoidn-*.dist-info) | xz -T0 -6 > .device-oidn/oidn.tar.xz
rm -rf "$t"; du -sh .device-mesa .device-py .device-oidn
