#!/usr/bin/env bash
# Installs what rtlab needs on a fresh Debian/Ubuntu machine: Mesa EGL/GL, Xvfb and xdotool
# (window tests), Assimp (FBX), then the Python package with its dev extra. Safe to run again.
set -euo pipefail
cd "$(dirname "$0")/.."
. scripts/python.sh

missing=()
ldconfig -p 2>/dev/null | grep -q 'libEGL.so.1 ' || missing+=(libegl1)
ldconfig -p 2>/dev/null | grep -q 'libGLX_mesa.so.0 ' || missing+=(libglx-mesa0)
[ -d /usr/lib/x86_64-linux-gnu/dri ] || [ -d /usr/lib/aarch64-linux-gnu/dri ] || missing+=(libgl1-mesa-dri)
command -v Xvfb >/dev/null || missing+=(xvfb)
command -v xdotool >/dev/null || missing+=(xdotool)
ldconfig -p 2>/dev/null | grep -q 'libassimp.so.5 ' || missing+=(libassimp5)  # FBX and Assimp's formats (pyassimp)
if [ ${#missing[@]} -gt 0 ]; then
    if command -v apt-get >/dev/null; then
        SUDO=""
        [ "$(id -u)" -eq 0 ] || SUDO=sudo
        echo "setup: installing ${missing[*]}"
        $SUDO apt-get update -qq
        DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq "${missing[@]}" >/dev/null
    else
        echo "setup: please install ${missing[*]} (Mesa EGL/GL, Xvfb, xdotool, Assimp) with your package manager" >&2
    fi
fi

# Vulkan with ray tracing for the Slang backends' tests (tracer=vulkan): Mesa's lavapipe from
# Mesa 25 (Debian 12's own Mesa 22.3 has no ray tracing; bookworm-backports has 25.0.7)
mesa=$(dpkg-query -W -f='${Version}' mesa-vulkan-drivers 2>/dev/null || true)
if command -v apt-get >/dev/null && [ "${mesa%%.*}" != "25" ] && [ "${mesa%%.*}" != "26" ]; then
    SUDO=""
    [ "$(id -u)" -eq 0 ] || SUDO=sudo
    if grep -q 'VERSION_CODENAME=bookworm' /etc/os-release 2>/dev/null; then
        echo "setup: installing Mesa's Vulkan drivers (lavapipe, ray tracing) from bookworm-backports"
        echo "deb http://deb.debian.org/debian bookworm-backports main" | $SUDO tee /etc/apt/sources.list.d/backports.list >/dev/null
        $SUDO apt-get update -qq
        DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq -t bookworm-backports mesa-vulkan-drivers libvulkan1 >/dev/null
    else
        DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq mesa-vulkan-drivers libvulkan1 >/dev/null || true
        echo "setup: tracer=vulkan needs Mesa >= 25 (lavapipe with ray tracing) or a GPU driver" >&2
    fi
fi

# (re)install when a package is missing or `app` resolves to another checkout
if ! $PY -I -c "import sys, app, core, rt, scenes, moderngl, embreex, imgui_bundle, PIL, trimesh, numba, matplotlib, flip_evaluator, slangpy, hypothesis, pytest, xdist, imagecodecs, OpenEXR, pyassimp, assimp_py
sys.exit(0 if app.__file__.startswith('$PWD/') else 1)" 2>/dev/null; then
    echo "setup: installing rtlab and its Python dependencies"
    $PY -m pip install -q --disable-pip-version-check -e '.[dev]'
fi

# The ray-tracing kernels are not compiled here: nothing waits for them. The viewer compiles them in
# the background while it shows the forward pass, `rtlab shot` of a ray-traced pass compiles what
# it needs and says so, and `rtlab warmup` compiles every pass ahead (scripts/test.sh runs it).
$PY - <<'PY' 2>/dev/null || true
from rt.backends import COMPILED_KEYS, kernels_ready
from rt.embree.compile_log import last_seconds

if not kernels_ready():
    known = [last_seconds(k) for k in COMPILED_KEYS]
    took = f"; {sum(known):.0f} s of compiling here last time" if all(t is not None for t in known) else ""
    print(f"setup: ray-traced passes compile their kernels on first use (once per version{took}); "
          "`rtlab warmup` compiles them all ahead")
PY
