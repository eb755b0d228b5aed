"""The viewer's own frame rate, measured as a user sees it (issue 38: >= 60 fps with gi_1+svgf on a
GPU backend): `rtlab view` run for N loop iterations (N, default 300), then the frames rendered per
second (Renderer.frames_made) and the UI loop's rate over the last four fifths of them.

    PYTHONPATH=. python3 scripts/viewer_fps.py SCENE [rtlab view's options]
    PYTHONPATH=. xvfb-run -a python3 scripts/viewer_fps.py arcade --pass ao --size 320x180

It needs a display: here Xvfb (above). A window without one, through GLFW's null platform and
EGL, was tried and fails both on Mesa here ("EGL is not or could not be initialized") and on the
lent GPU machine, whose NVIDIA EGL has no config with window surfaces ("Failed to find a suitable
EGLConfig"): that machine has no X server, so the viewer's rate is not measured there."""
import os
import sys
import time

import app.viewer as viewer_module
from app.cli import build_parser


def main(argv) -> int:
    n = int(os.environ.get("N", 300))
    if not os.environ.get("DISPLAY"):
        print("viewer_fps: no display ($DISPLAY); run it under xvfb-run", file=sys.stderr)
        return 2
    args = build_parser().parse_args(["view", *argv, "--exit-after", str(n)])
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
