"""`rtlab view`: GLFW window + ModernGL + ImGui (imgui-bundle's native backends).

The scene renders through the same Renderer as `rtlab shot`; the panel edits the same
option keys. A failed scene load or option shows its error in the panel and keeps the
previous state.
"""
from __future__ import annotations

import ctypes
import gc
import json
import os
import sys
import time
from collections import deque
from concurrent.futures import FIRST_COMPLETED, ThreadPoolExecutor, wait
from pathlib import Path

import numpy as np

from app.camera import Camera
from app.compare import DIFF, check_compare
from app.fly_camera import FlyCamera, FlyInput
from app.gl_context import fullscreen, set_uniform, wrap_current_context
from app.graph import check_denoise
from app.headless import parse_size
from app.image_io import write_npy, write_png
from app.loading import open_scene
from app.options import Options
from app.overlays import split_overlay, status_overlay
from app.passes import check_pass
from app.profiler import Profiler
from app.renderer import Renderer
from app.split_view import Comparison, Track
from app.ui_panel import Panel
from app.warmup import BackgroundWarmup
from core.errors import UserError
from rt.backends import kernels_ready, return_freed_memory
from scenes.builtin import DEFAULT_SCENE
from scenes.loaders import is_builtin, load_scene
from scenes.model import View
from scenes.progress import reporting

LOAD_GRACE_S = 0.25  # a file that opens within this is switched to in the same frame
NO_DISPLAY = ("no display to open a window on (DISPLAY is not set); for a headless image run: "
              "rtlab shot {scene} --out {scene}.png")


def has_display() -> bool:
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


UI_HZ = 240  # the UI loop's ceiling (Viewer.run)
# its ceiling where GL is a CPU rasteriser: there each loop's panel and blit take CPU from the
# tracing threads (arcade at 640x360 on 2 cores: AO 13-14 frames rendered/s with the loop at
# ~170/s, 19 at 60/s; GI 5.2 -> 7.1), and a display shows no more than its refresh anyway. The
# loop wakes early where a frame is done (Viewer._pause), so that small frames are not held to it.
SOFTWARE_UI_HZ = 60
SWITCH_INTERVAL = 0.0005  # s: how often the interpreter hands the GIL on while the viewer runs


class Viewer:
    def __init__(self, args):
        import glfw

        self.glfw = glfw
        self.scene_spec = args.scene or DEFAULT_SCENE
        width, height = parse_size(args.size)
        self.options = Options()
        self.options.apply(args.set or [])
        self.pass_name = check_pass(args.pass_name)
        check_denoise(self.pass_name, self.options)
        self.split = float(getattr(args, "split", 0.5))  # the divider, a fraction of the width
        check_compare(self.pass_name, getattr(args, "compare", None), self.split)
        # a bad bookmarks file or scene: one line before any window opens
        bookmarks = read_bookmarks(args.bookmarks) if getattr(args, "bookmarks", None) else None
        scene = open_scene(self.scene_spec)
        if not glfw.init():
            raise UserError(NO_DISPLAY.format(scene=self.scene_spec))
        glfw.window_hint(glfw.CONTEXT_VERSION_MAJOR, 4)
        glfw.window_hint(glfw.CONTEXT_VERSION_MINOR, 3)
        glfw.window_hint(glfw.OPENGL_PROFILE, glfw.OPENGL_CORE_PROFILE)
        glfw.window_hint(glfw.OPENGL_FORWARD_COMPAT, True)
        glfw.window_hint(glfw.SCALE_TO_MONITOR, True)
        self.window = glfw.create_window(width, height, f"rtlab - {scene.name}", None, None)
        if not self.window:
            glfw.terminate()
            raise UserError("cannot open an OpenGL 4.3 window on this display; try rtlab shot")
        glfw.make_context_current(self.window)
        glfw.swap_interval(0)  # vsync off: frame times mean something
        self.ctx = wrap_current_context()
        self.scene = scene
        self.renderer = Renderer(self.ctx, scene, self.options, Profiler(deferred=True), prefetch=True)
        self.renderer.reuse_static_frames = True
        self.resolution_scale = 1.0  # of the window, for every frame
        self.motion_scale = 0.5  # extra scale while the camera moves, so flying stays interactive
        self.moving = False
        # ray-traced frames compute on a worker thread; the window keeps drawing the last image
        self.pool = ThreadPoolExecutor(1, thread_name_prefix="rtlab-trace")
        self.main = Track(self.renderer, self.pool)
        self.comparison: Comparison | None = None  # the split view's right side
        self.dragging_split = False
        self.fly = FlyCamera(Camera.from_view(scene.default_view(), scene.diagonal), scene.diagonal)
        self.show_ui = True
        self.show_profiler = True
        self.show_help = False  # F1
        self.warmup = None if kernels_ready() else BackgroundWarmup()  # a cold start compiles while you look
        self.screenshot_dir = "rtlab-screenshots"  # F12 writes here (the panel names it)
        self.frame_times: deque = deque(maxlen=240)
        self.panel = Panel(self)
        self.pending_scene: str | None = None
        self.loading = None  # (spec, future of its scene, [its loader's stage]) while a file opens in the background
        self.bookmarks: dict[str, View] = bookmarks or dict(scene.views)  # keys 1-9 and the panel's buttons
        self.fb_size = glfw.get_framebuffer_size(self.window)
        self._init_imgui()
        glfw.set_drop_callback(self.window, self._dropped)
        if getattr(args, "compare", None):
            self.set_compare(args.compare)
        if bookmarks:
            self.panel.message = f"loaded {len(bookmarks)} bookmarks from {args.bookmarks}"

    @property
    def job(self):
        return self.main.job

    @property
    def future(self):
        return self.main.future

    def _init_imgui(self) -> None:
        from imgui_bundle import imgui

        self.imgui = imgui
        imgui.create_context()
        io = imgui.get_io()
        io.set_ini_filename("")
        xscale, _ = self.glfw.get_window_content_scale(self.window)
        if xscale > 1.01:
            imgui.get_style().scale_all_sizes(xscale)
            io.font_global_scale = xscale
        address = ctypes.cast(self.window, ctypes.c_void_p).value
        imgui.backends.glfw_init_for_opengl(address, True)
        imgui.backends.opengl3_init("#version 330")

    # -- actions --------------------------------------------------------------------------
    def request_scene(self, spec: str) -> None:
        self.pending_scene = spec

    def set_compare(self, mode: str | None) -> None:
        """Split the view: `mode` (a pass, or diff) right of the divider; None: one pass."""
        check_compare(self.pass_name, mode, self.split)
        if self.comparison is not None:
            self.comparison.release()
            self.comparison = None
        if mode:
            self.comparison = Comparison(self.ctx, self.scene, self.options, mode, self.pool)

    def swap_sides(self) -> None:
        if self.comparison is not None and self.comparison.mode != DIFF:
            self.pass_name, mode = self.comparison.mode, self.pass_name
            self.set_compare(mode)

    def _drop_job(self) -> None:
        """Wait for the frames being traced and discard them (their scene or state is going away)."""
        self.main.drop()
        if self.comparison is not None:
            self.comparison.track.drop()

    def _load_pending_scene(self) -> None:
        """Open the requested scene: a built-in one here, a file on a thread (the window keeps
        drawing the old scene, the panel says what the loader is doing) unless it opens at once."""
        spec, self.pending_scene = self.pending_scene, None
        if is_builtin(spec):
            self._scene_loaded(spec, lambda: load_scene(spec))
            return
        said = ["reading"]

        def load():
            with reporting(lambda text: said.__setitem__(0, text)):
                return load_scene(spec)

        from concurrent.futures import ThreadPoolExecutor

        pool = ThreadPoolExecutor(1, thread_name_prefix="rtlab-load")
        self.loading = (spec, pool.submit(load), said)
        pool.shutdown(wait=False)
        self._poll_loading(wait=LOAD_GRACE_S)

    def _poll_loading(self, wait: float = 0.0) -> None:
        """The background load's stage in the panel, or its scene (or error) once it is done."""
        from concurrent.futures import TimeoutError as Pending

        spec, future, said = self.loading
        try:
            future.result(timeout=wait)
        except Pending:
            self.panel.message = f"opening {Path(spec).name}: {said[0]}"
            return
        except Exception:  # noqa: BLE001 - said by _scene_loaded, which reads the result again
            pass
        self.loading = None
        self.panel.message = ""
        self._scene_loaded(spec, future.result)

    def _scene_loaded(self, spec: str, result) -> None:
        """Switch to the scene result() gives (on the GL thread), or show its error and keep the old one."""
        try:
            scene = result()
        except UserError as e:
            self.panel.error = str(e)  # keep the old scene
            return
        self._drop_job()
        self.scene, self.scene_spec = scene, spec
        self.renderer.set_scene(scene)
        gc.collect()  # the old scene's arrays (hundreds of MB for large scenes) go now
        return_freed_memory()  # and back to the OS, not kept for the frames' reuse
        if self.comparison is not None:
            self.comparison.set_scene(scene)
        self.fly = FlyCamera(Camera.from_view(scene.default_view(), scene.diagonal), scene.diagonal)
        self.bookmarks = dict(scene.views)
        self.glfw.set_window_title(self.window, f"rtlab - {scene.name}")
        self.panel.error = ""

    def go_to_view(self, name: str) -> None:
        view = self.bookmarks[name]
        self.fly.set_camera(Camera.from_view(view, self.scene.diagonal))

    def save_bookmarks(self, path: str) -> None:
        from app.image_io import write_text

        data = {name: v.__dict__ for name, v in self.bookmarks.items()}
        data["current"] = View("current", *(tuple(map(float, x)) for x in
                                            (self.fly.camera.eye, self.fly.camera.target, self.fly.camera.up)),
                               self.fly.camera.fov).__dict__
        write_text(path, json.dumps(data, indent=2))
        self.panel.message = f"saved {len(data)} bookmarks to {path}"

    def load_bookmarks(self, path: str) -> None:
        """A file saved by save_bookmarks (read_bookmarks); a bad one leaves those in use."""
        views = read_bookmarks(path)
        self.bookmarks = views
        self.panel.message = f"loaded {len(views)} bookmarks"

    def _dropped(self, window, paths) -> None:
        """A file dropped on the window: the first scene file among them is opened, or else the
        first environment map lights the scene (option env)."""
        from scenes.loaders import EXTENSIONS
        from scenes.loaders.envmap import SUFFIXES

        scenes = [p for p in paths if Path(p).suffix.lower() in EXTENSIONS]
        maps = [p for p in paths if Path(p).suffix.lower() in SUFFIXES]
        if scenes:
            self.request_scene(scenes[0])
        elif maps:
            try:
                self.options.set("env", maps[0])
                self.panel.message, self.panel.error = f"environment: {Path(maps[0]).name}", ""
            except UserError as e:
                self.panel.error = str(e)
        else:
            self.panel.error = (f"not a scene file ({', '.join(EXTENSIONS)}) or an environment map "
                                f"({', '.join(SUFFIXES)}): {', '.join(paths)[:200]}")

    def screenshot(self, path: str | None = None) -> str:
        """The window as a PNG (and the linear image as .npy): at `path`, or (F12) a new file in
        the panel's screenshots folder, created if need be."""
        stamp = time.strftime("%Y%m%d-%H%M%S")
        if path is None:
            folder = Path(self.screenshot_dir or ".")
            try:
                folder.mkdir(parents=True, exist_ok=True)
            except OSError as e:
                raise UserError(f"cannot create the screenshots folder {folder}: {e.strerror}") from None
            path = str(folder / f"rtlab-{self.scene.name.replace(':', '_')}-{self.pass_name}-{stamp}.png")
        w, h = self.fb_size
        data = np.frombuffer(self.ctx.screen.read(viewport=(0, 0, w, h), components=3), np.uint8)
        write_png(path, data.reshape(h, w, 3)[::-1])
        if self.renderer.frame is not None:
            write_npy(str(Path(path).with_suffix(".npy")), self.renderer.read_linear())
        self.panel.message = f"saved {path}"
        return path

    # -- input -----------------------------------------------------------------------------
    def _input(self) -> FlyInput:
        imgui, glfw, win = self.imgui, self.glfw, self.window
        io = imgui.get_io()
        keys = not io.want_capture_keyboard
        down = (lambda k: glfw.get_key(win, k) == glfw.PRESS) if keys else (lambda k: False)
        move = (float(down(glfw.KEY_D)) - float(down(glfw.KEY_A)),
                float(down(glfw.KEY_E)) - float(down(glfw.KEY_Q)),
                float(down(glfw.KEY_W)) - float(down(glfw.KEY_S)))
        look = (0.0, 0.0)
        if not io.want_capture_mouse and glfw.get_mouse_button(win, glfw.MOUSE_BUTTON_RIGHT) == glfw.PRESS:
            look = (float(io.mouse_delta.x), float(io.mouse_delta.y))
        scroll = 0.0 if io.want_capture_mouse else float(io.mouse_wheel)
        fast = down(glfw.KEY_LEFT_SHIFT) or down(glfw.KEY_RIGHT_SHIFT)
        slow = down(glfw.KEY_LEFT_CONTROL) or down(glfw.KEY_RIGHT_CONTROL)
        if keys:
            self._shortcuts()
        return FlyInput(move, look, fast, slow, scroll)

    def _shortcuts(self) -> None:
        imgui = self.imgui
        K = imgui.Key
        pressed = lambda k: imgui.is_key_pressed(k, False)  # noqa: E731
        if pressed(K.escape):
            self.glfw.set_window_should_close(self.window, True)
        if pressed(K.g) or pressed(K.f2):
            self.show_ui = not self.show_ui
        if pressed(K.p):
            self.show_profiler = not self.show_profiler
        if pressed(K.f1) or pressed(K.h):
            self.show_help = not self.show_help
        if pressed(K.r):
            self.renderer.reset()
        if pressed(K.f12):
            try:
                self.screenshot()
            except UserError as e:
                self.panel.error = str(e)
        names = list(self.bookmarks)
        for k in range(9):
            if pressed(getattr(K, f"_{k + 1}")) and k < len(names):
                self.go_to_view(names[k])

    # -- loop ------------------------------------------------------------------------------
    def frame(self, dt: float, start_new: bool = True) -> None:
        imgui, glfw = self.imgui, self.glfw
        self.fb_size = glfw.get_framebuffer_size(self.window)
        self.renderer.profiler.collect()  # last frame's GPU times: done by now, read without a wait
        imgui.backends.opengl3_new_frame()
        imgui.backends.glfw_new_frame()
        imgui.new_frame()
        self.moving = self.fly.update(dt, self._input())
        if self.show_ui:
            self.panel.draw(imgui)
        elif self.show_profiler:
            self.panel.draw_profiler(imgui)
        if self.warmup is not None and not self.warmup.running:  # the background compile ended
            self.panel.error = self.panel.error or self.warmup.failed
            self.warmup = None
        if self.comparison is not None:
            split_overlay(self, imgui)
        status_overlay(self, imgui)
        if self.show_help:
            self.panel.draw_help(imgui)
        imgui.render()
        if self.pending_scene:
            self._load_pending_scene()
        elif self.loading is not None:
            self._poll_loading()
        w, h = self.fb_size
        self.ctx.screen.use()
        self.ctx.screen.viewport = (0, 0, max(w, 1), max(h, 1))
        self.ctx.screen.clear(0.08, 0.08, 0.09, 1.0)
        if w > 0 and h > 0:  # minimised windows are 0x0: skip rendering, keep the loop alive
            # a reprojected accumulation needs the same size while moving (its history is per pixel)
            shrink = self.moving and not self.options.get("reproject")
            scale = self.resolution_scale * (self.motion_scale if shrink else 1.0)
            rw, rh = max(1, int(w * scale)), max(1, int(h * scale))
            try:
                self.main.advance(self.fly.camera, rw, rh, self.pass_name, start_new)
                if self.comparison is not None:
                    c = self.comparison
                    c.track.advance(self.fly.camera, rw, rh, c.pass_name, start_new)
            except UserError as e:
                self.panel.error = str(e)
            notices = self.renderer.notices  # said once: how images move between GL and the device
            if notices:
                self.panel.message = notices[-1]
                notices.clear()
            self._show(w, h)
        imgui.backends.opengl3_render_draw_data(imgui.get_draw_data())

    def _show(self, w: int, h: int) -> None:
        """The main image, and in a split view the comparison right of the divider, labelled."""
        self.ctx.screen.use()
        self.ctx.screen.viewport = (0, 0, w, h)
        prog, vao = fullscreen(self.ctx, "blit.frag")
        sides = [(self.renderer.frame.channels["display"] if self.renderer.frame is not None else None, None)]
        if self.comparison is not None:
            x = int(round(self.split * w))
            sides.append((self.comparison.texture(self.renderer), (x, 0, max(w - x, 0), h)))
        for texture, scissor in sides:
            if texture is None:
                continue
            self.ctx.scissor = scissor
            texture.filter = (self.ctx.LINEAR, self.ctx.LINEAR)
            texture.use(0)
            set_uniform(prog, "image", 0)
            vao.render(vertices=3)
        self.ctx.scissor = None

    def wait_for_frame(self) -> None:
        """Block until the frames being traced are shown (tests, --exit-after)."""
        if self.main.busy or (self.comparison is not None and self.comparison.track.busy):
            self.main.wait()
            if self.comparison is not None:
                self.comparison.track.wait()
            self.frame(0.0, start_new=False)

    def _pause(self, seconds: float, early: bool) -> None:
        """Sleep out the rest of the loop's period, or with `early` until a frame being traced is
        done (the next one is then started at once: on a CPU rasteriser, where the period is long)."""
        tracks = [self.main] + ([self.comparison.track] if self.comparison is not None else [])
        pending = [t.future for t in tracks if t.future is not None and not t.future.done()] if early else []
        if pending:
            wait(pending, timeout=seconds, return_when=FIRST_COMPLETED)
        else:
            time.sleep(seconds)

    def run(self, exit_after: int = 0, screenshot: str | None = None) -> int:
        """The UI loop, at most UI_HZ iterations a second (SOFTWARE_UI_HZ on a CPU rasteriser). A
        GPU backend's frames are made by the tracing worker's Python (recording and submitting the
        device's work), which needs the GIL that the UI loop's Python holds: the loop sleeps out
        the rest of its period (_pause), and the interpreter hands the GIL over every 0.5 ms
        instead of 5 while the viewer runs."""
        glfw = self.glfw
        software = self.renderer.software_gl()
        period = 1.0 / (SOFTWARE_UI_HZ if software else UI_HZ)
        last = time.perf_counter()
        frames = 0
        switch = sys.getswitchinterval()
        sys.setswitchinterval(SWITCH_INTERVAL)
        try:
            while not glfw.window_should_close(self.window):
                glfw.poll_events()
                now = time.perf_counter()
                dt, last = now - last, now
                self.frame(min(dt, 0.25))
                self.frame_times.append(dt * 1e3)
                frames += 1
                if exit_after and frames >= exit_after:
                    self.wait_for_frame()
                    if screenshot:
                        self.screenshot(screenshot)
                    break
                glfw.swap_buffers(self.window)
                spare = period - (time.perf_counter() - now)
                if spare > 0:
                    self._pause(spare, software)  # the GIL and the cores are the worker's meanwhile
        finally:
            sys.setswitchinterval(switch)
        return 0

    def close(self) -> None:
        if self.warmup is not None:
            self.warmup.stop()
        self._drop_job()
        self.pool.shutdown(wait=True)
        imgui = self.imgui
        imgui.backends.opengl3_shutdown()
        imgui.backends.glfw_shutdown()
        imgui.destroy_context()
        if self.comparison is not None:
            self.comparison.release()
        self.renderer.release()
        self.glfw.destroy_window(self.window)
        self.glfw.terminate()


def read_bookmarks(path: str) -> dict[str, View]:
    """A file saved by save_bookmarks: {name: {eye, target, up, fov}}. Anything else (a list,
    a vector of two numbers, a camera looking at its own eye) is refused with one line."""
    try:
        data = json.loads(Path(path).read_text())
        if not isinstance(data, dict) or not data:
            raise ValueError("expected an object of named views, as 'save bookmarks' writes")
        return {str(name): _bookmark(str(name), d) for name, d in data.items()}
    except (OSError, ValueError, KeyError, TypeError, RecursionError) as e:
        raise UserError(f"cannot load bookmarks from {path}: {e}") from None


def _bookmark(name: str, d) -> View:
    """One saved view, checked: three finite numbers a vector, a field of view within (0, 180)."""
    if not isinstance(d, dict):
        raise ValueError(f"{name}: expected an object with eye, target, up, fov")

    def vector(key: str, default=None) -> tuple:
        v = d.get(key, default)
        if not isinstance(v, (list, tuple)) or len(v) != 3 or not all(
                isinstance(x, (int, float)) and not isinstance(x, bool) and np.isfinite(x) for x in v):
            raise ValueError(f"{name}: {key} must be three finite numbers, got {v!r}")
        return tuple(float(x) for x in v)

    eye, target, up = vector("eye"), vector("target"), vector("up", (0.0, 1.0, 0.0))
    fov = d.get("fov", 60.0)
    if not isinstance(fov, (int, float)) or isinstance(fov, bool) or not 0.0 < fov < 180.0:
        raise ValueError(f"{name}: fov must be a number of degrees within (0, 180), got {fov!r}")
    if np.allclose(eye, target):
        raise ValueError(f"{name}: eye and target are the same point")
    return View(name, eye, target, up, float(fov))


def run_viewer(args) -> int:
    scene = args.scene or DEFAULT_SCENE
    if not has_display():
        raise UserError(NO_DISPLAY.format(scene=scene))
    if args.screenshot and not args.exit_after:
        args.exit_after = 1
    from rt.backends import resolve

    gpu = resolve("auto")
    if gpu != "embree" and not any(s.strip().startswith("tracer=") for s in (args.set or [])):
        print(f"rtlab: this machine has a GPU with ray tracing: --set tracer={gpu} (or the panel's tracer) "
              f"traces on it", flush=True)
    viewer = Viewer(args)
    try:
        return viewer.run(args.exit_after, args.screenshot)
    finally:
        viewer.close()


if __name__ == "__main__":  # pragma: no cover
    sys.exit(run_viewer(None))
