#!/usr/bin/env bash
# The main job: the viewer on the default scene, or (no display) a headless screenshot of it.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
. scripts/python.sh
if [ -n "${DISPLAY:-}${WAYLAND_DISPLAY:-}" ]; then
    exec $PY -m app.cli view arcade "$@"
else
    echo "no display: rendering a headless screenshot instead (rtlab shot)"
    exec $PY -m app.cli shot arcade --size 1280x720 --out arcade.png "$@"
fi
