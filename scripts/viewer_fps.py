"""The viewer's own frame rate, measured as a user sees it (issue 38: >= 60 fps with gi_1+svgf on a
GPU backend): `rtlab view` run for N loop iterations (N, default 300), then the frames rendered per
second (Renderer.frames_made) and the UI loop's rate over the last four fifths of them.

    PYTHONPATH=. python3 scripts/viewer_fps.py SCENE [rtlab view's options]
    PYTHONPATH=. xvfb-run -a python3 scripts/viewer_fps.py arcade --pass ao --size 320x180

With a display ($DISPLAY) the window opens there; without one GLFW's null platform is asked for
and the context comes from EGL, which works where EGL offers configs with window surfaces (Mesa's).
The viewer's own has_display check is bypassed for that, which is why this is a script and not a
`rtlab view` option. NVIDIA's headless EGL (the lent GPU machine: no X server) offers none, so GLFW
stops with "EGL: Failed to find a suitable EGLConfig" there: it needs an X server on that GPU."""
import os
import sys
import time

import glfw

if not os.environ.get("DISPLAY"):
    glfw.init_hint(glfw.PLATFORM, glfw.PLATFORM_NULL)
_window_hint = glfw.window_hint


def _egl_hint(key, value):
    """Every window hint the viewer gives, and an EGL context (GLX needs an X server)."""
    _window_hint(key, value)
    _window_hint(glfw.CONTEXT_CREATION_API, glfw.EGL_CONTEXT_API)


glfw.window_hint = _egl_hint

import app.viewer as viewer_module  # noqa: E402
from app.cli import build_parser  # noqa: E402


def main(argv) -> int:
    n = int(os.environ.get("N", 300))
    args = build_parser().parse_args(["view", *argv, "--exit-after", str(n)])
    viewer_module.has_display = lambda: True
    viewer = viewer_module.Viewer(args)
    marks = []
    frame = viewer.frame

    def timed(dt, start_new=True):  # each loop iteration's end and the frames rendered so far
        frame(dt, start_new)
        marks.append((time.perf_counter(), viewer.renderer.frames_made))

    viewer.frame = timed
    try:
        viewer.run(n)
    finally:
        skip = len(marks) // 5
        (t0, f0), (t1, f1) = marks[skip], marks[-1]
        print(f"viewer {' '.join(argv)}: {(len(marks) - 1 - skip) / (t1 - t0):.0f} loop iterations/s, "
              f"{(f1 - f0) / (t1 - t0):.1f} frames rendered/s ({f1 - f0} frames in {t1 - t0:.2f} s); "
              f"GL {viewer.ctx.info['GL_RENDERER']}", flush=True)
        viewer.close()
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
