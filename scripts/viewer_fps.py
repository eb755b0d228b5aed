"""The viewer's own frame rate, measured as a user sees it (issue 38: >= 60 fps with gi_1+svgf on a
GPU backend): `rtlab view` run for N loop iterations (N, default 300), then the frames rendered per
second (Renderer.frames_made) and the UI loop's rate over the last four fifths of them.

    PYTHONPATH=. python3 scripts/viewer_fps.py SCENE [rtlab view's options]
    PYTHONPATH=. xvfb-run -a python3 scripts/viewer_fps.py arcade --pass ao --size 320x180

With a display ($DISPLAY) the viewer opens its window. Without one (the lent GPU machine has no X
server, and its NVIDIA EGL no config with window surfaces for GLFW), the same Viewer runs in an
offscreen window: GLFW stood in for by an EGL context whose default framebuffer is a texture of
the window's size, and ImGui's GLFW backend by the display size set each frame; the panel, the
renderer, the frame tracks and the blit are the viewer's own. Each "swap" waits for GL to finish
(glFinish) and shows nothing: the offscreen rate leaves out the presentation (the window system's
copy; under Xvfb here it holds the loop to ~100 iterations/s) and queues no frames.

Kernels not yet compiled for this version are compiled first (`rtlab warmup`), so that the viewer's
background compile does not run through the measurement (on a fresh 16-core machine it ran 15
compile processes beside the viewer)."""
import os
import subprocess
import sys
import time
import types

import app.viewer as viewer_module
from app.cli import build_parser


class _OffscreenGlfw(types.ModuleType):
    """What the viewer calls of glfw, for one offscreen window (created with its context)."""

    PRESS = 1

    def __init__(self):
        super().__init__("glfw")
        self.ctx, self.size = None, (0, 0)

    def __getattr__(self, name):  # window hints, keys, buttons: constants nobody presses
        if name.isupper():
            return 0
        raise AttributeError(name)

    def create_window(self, width, height, *_):
        import moderngl

        self.ctx = moderngl.create_standalone_context(backend="egl", require=430)
        self.size = (width, height)
        self.ctx._screen = self.ctx.simple_framebuffer(self.size)  # the window's framebuffer
        return 1

    def init(self):
        return True

    def get_framebuffer_size(self, window):
        return self.size

    def get_window_content_scale(self, window):
        return 1.0, 1.0

    def window_should_close(self, window):
        return False

    def swap_buffers(self, window):
        self.ctx.finish()

    def get_key(self, window, key):
        return 0

    def get_mouse_button(self, window, button):
        return 0

    def get_current_context(self):  # no GLFW context: GL's functions are looked up through EGL
        return None

    def _nothing(self, *args):
        return None

    window_hint = make_context_current = swap_interval = set_drop_callback = poll_events = _nothing
    set_window_title = set_window_should_close = destroy_window = terminate = _nothing


def _offscreen() -> _OffscreenGlfw:
    """The stand-ins installed: glfw, the viewer's context and ImGui's GLFW backend."""
    from imgui_bundle import imgui

    fake = _OffscreenGlfw()
    sys.modules["glfw"] = fake
    viewer_module.wrap_current_context = lambda: fake.ctx
    last = [time.perf_counter()]

    def new_frame():  # what ImGui's GLFW backend would set: the display's size and the time step
        io = imgui.get_io()
        io.display_size = fake.size
        now = time.perf_counter()
        io.delta_time, last[0] = max(now - last[0], 1e-6), now

    imgui.backends.glfw_init_for_opengl = lambda *a: True
    imgui.backends.glfw_new_frame = new_frame
    imgui.backends.glfw_shutdown = lambda: None
    return fake


def main(argv) -> int:
    from rt.backends import kernels_ready

    if not kernels_ready():
        subprocess.run([sys.executable, "-m", "app.cli", "warmup"], check=False)
    n = int(os.environ.get("N", 300))
    window = "window" if os.environ.get("DISPLAY") else "offscreen"
    if window == "offscreen":
        _offscreen()
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
        print(f"viewer ({window}) {' '.join(argv)}: {(len(marks) - 1 - skip) / (t1 - t0):.0f} loop iterations/s, "
              f"{(f1 - f0) / (t1 - t0):.1f} frames rendered/s ({f1 - f0} frames in {t1 - t0:.2f} s); "
              f"GL {viewer.ctx.info['GL_RENDERER']}", flush=True)
        viewer.close()
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
