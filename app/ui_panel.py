"""ImGui panels of the viewer: settings (like Falcor's Mogwai), profiler, help.

Every option is drawn from its dataclass spec, so the UI and `--set` share keys and ranges.
"""
from __future__ import annotations

import numpy as np

from app.compare import DIFF
from app.graph import denoises, option_groups
from app.passes import ALL
from core.errors import UserError

KEYS_HELP = [
    ("W A S D", "move"), ("Q / E", "down / up"), ("right mouse drag", "look"), ("Shift / Ctrl", "faster / slower"),
    ("scroll wheel", "change speed"), ("1 - 9", "camera bookmarks"), ("F12", "screenshot (PNG + .npy)"),
    ("G or F2", "hide / show UI"), ("P", "profiler"), ("R", "reset accumulation"), ("F1 or H", "this help"),
    ("left mouse drag", "the split view's divider"), ("drop a file", "open a .gltf/.glb/.obj/.ply/.fbx scene"),
    ("Esc", "quit"),
]
PANEL_WIDTH = 460


def draw_option(imgui, options, key: str) -> bool:
    """One widget for one option key; returns True if the user changed it."""
    spec = options.spec(key)
    value = options.get(key)
    label = key
    changed, new = False, value
    if isinstance(value, bool):
        changed, new = imgui.checkbox(label, value)
    elif spec.get("choices"):
        choices = list(spec["choices"])
        idx = choices.index(value) if value in choices else 0
        changed, idx = imgui.combo(label, idx, choices)
        new = choices[idx]
    elif isinstance(value, int):
        lo, hi = spec.get("lo", 0), spec.get("hi", 100)
        if hi - lo <= 64:
            changed, new = imgui.slider_int(label, value, int(lo), int(hi))
        else:
            changed, new = imgui.input_int(label, value)
            new = int(np.clip(new, lo, hi))
    elif isinstance(value, float):
        lo, hi = float(spec.get("lo") or 0.0), float(spec.get("hi") or 1.0)
        if hi / max(lo, 1e-9) > 1e3 or hi > 20:
            changed, new = imgui.drag_float(label, value, max(abs(value) * 0.01, 1e-3), lo, hi, "%.3f")
        else:
            changed, new = imgui.slider_float(label, value, lo, hi, "%.3f")
    else:
        changed, new = imgui.input_text(label, str(value), imgui.InputTextFlags_.enter_returns_true.value)
    if spec.get("help") and imgui.is_item_hovered():
        imgui.set_tooltip(spec["help"])
    if changed and new != value:
        options.set(key, new if not isinstance(new, str) else new.strip())
        return True
    return False


def frame_wide_keys(options) -> list[str]:
    """The options of every mode (the frame-wide group, app/options.py: GlobalOptions, in its order,
    the environment's and the textures')."""
    return [k for k in options.keys() if "." not in k or k.startswith(("env.", "textures."))]


def option_keys_for(options, pass_name: str) -> list[str]:
    """The option keys of the mode's graph (app/graph.py): the mode's own, then its passes'."""
    return [k for g in option_groups(pass_name) for k in options.keys() if k.startswith(g + ".")]


def keep_on_screen(imgui) -> None:
    """Move the current window back into the display when a resize left it outside."""
    io = imgui.get_io()
    pos, size = imgui.get_window_pos(), imgui.get_window_size()
    w, h = io.display_size.x, io.display_size.y
    x = min(max(pos.x, 0.0), max(w - min(size.x, w), 0.0))
    y = min(max(pos.y, 0.0), max(h - 40.0, 0.0))
    if (x, y) != (pos.x, pos.y):
        imgui.set_window_pos((x, y))


class Panel:
    def __init__(self, viewer):
        self.v = viewer
        self.scene_path = ""
        self.camera_json = "cameras.json"
        self.error = ""
        self.message = ""
        self._stats = (None, None)  # (scene, its stats): made once a scene, not every UI frame

    def scene_stats(self) -> dict:
        """The scene's statistics (Scene.stats: its emitting triangles are found over every
        triangle, 1.5 ms a UI frame on the arcade and O(triangles) on a big file)."""
        scene, stats = self._stats
        if scene is not self.v.scene:
            self._stats = (self.v.scene, self.v.scene.stats())
        return self._stats[1]

    def draw(self, imgui) -> None:
        v = self.v
        imgui.set_next_window_pos((10, 10), imgui.Cond_.first_use_ever.value)
        imgui.set_next_window_size((PANEL_WIDTH, 640), imgui.Cond_.first_use_ever.value)
        imgui.begin("rtlab")
        keep_on_screen(imgui)
        imgui.push_item_width(imgui.get_window_width() * 0.5)  # room for the labels right of the fields
        if self.error:
            imgui.push_text_wrap_pos(0.0)  # the whole message, wrapped at the panel's edge
            imgui.text_colored((1.0, 0.35, 0.3, 1.0), self.error)
            imgui.pop_text_wrap_pos()
            if imgui.small_button("dismiss"):
                self.error = ""
        elif self.message:
            imgui.text_disabled(self.message)
        if imgui.collapsing_header("Scene", imgui.TreeNodeFlags_.default_open.value):
            from scenes.builtin import BUILTINS

            names = list(BUILTINS)
            current = v.scene_spec.partition(":")[0]
            idx = names.index(current) if current in names else -1
            changed, idx = imgui.combo("built-in", idx, names)
            if changed and idx >= 0:
                v.request_scene(names[idx])
            _, self.scene_path = imgui.input_text("file", self.scene_path)
            if imgui.button("open"):
                v.request_scene(self.scene_path.strip())
            imgui.same_line()
            if imgui.button("browse..."):
                self._browse()
            imgui.same_line()
            imgui.text_disabled("(or drop a file on the window)")
            st = self.scene_stats()
            imgui.text(f"{st['triangles']:,} triangles, {st['lights']} lights, "
                       f"{st['emissive_triangles']:,} emissive")
            studio = st["environment"] == "studio" and v.options.get("env") == "scene"
            imgui.text(f"environment: {st['environment']}" + (" (no lights in the file: env=black for none)"
                                                               if studio else ""))
        if imgui.collapsing_header("Render", imgui.TreeNodeFlags_.default_open.value):
            idx = ALL.index(v.pass_name)
            changed, idx = imgui.combo("pass", idx, list(ALL))
            if changed:
                v.pass_name = ALL[idx]
            self._compare(imgui)
            for key in frame_wide_keys(v.options):
                self._option(imgui, key)
            _, v.resolution_scale = imgui.slider_float("resolution scale", v.resolution_scale, 0.25, 1.0, "%.2f")
            _, v.motion_scale = imgui.slider_float("scale while moving", v.motion_scale, 0.25, 1.0, "%.2f")
            imgui.text(f"accumulated frames: {v.renderer.frame_count}")
            imgui.same_line()
            if imgui.button("reset (R)"):
                v.renderer.reset()
            for key in option_keys_for(v.options, v.pass_name):
                self._option(imgui, key)
        if imgui.collapsing_header("Camera"):
            cams = list(v.bookmarks)  # the scene's views, or the bookmarks file loaded
            for k, name in enumerate(cams[:9]):
                if imgui.button(f"{k + 1}: {name}"):
                    v.go_to_view(name)
                if k % 3 != 2 and k != len(cams[:9]) - 1:
                    imgui.same_line()
            self._camera_fields(imgui)
            _, v.fly.speed = imgui.drag_float("speed m/s", v.fly.speed, 0.05, 0.001, 10000.0)
            if imgui.button("copy camera string"):
                text = v.fly.camera.to_string()
                print(f'--camera "{text}"', flush=True)
                imgui.set_clipboard_text(text)
                self.message = "camera printed to the terminal and copied"
            _, self.camera_json = imgui.input_text("bookmarks file", self.camera_json)
            if imgui.button("save bookmarks"):
                self._guard(lambda: v.save_bookmarks(self.camera_json))
            imgui.same_line()
            if imgui.button("load bookmarks"):
                self._guard(lambda: v.load_bookmarks(self.camera_json))
        if imgui.collapsing_header("Screenshots"):
            _, v.screenshot_dir = imgui.input_text("F12 folder", v.screenshot_dir)
        imgui.text_disabled("F1: keys and mouse")
        imgui.pop_item_width()
        imgui.end()
        if v.show_profiler:
            self.draw_profiler(imgui)

    def _compare(self, imgui) -> None:
        """The split view: a second pass (or diff: FLIP against the reference) right of the divider."""
        v = self.v
        choices = ["(none)"] + list(ALL) + [DIFF]
        current = v.comparison.mode if v.comparison is not None else "(none)"
        changed, idx = imgui.combo("compare with", choices.index(current), choices)
        if changed:
            self._guard(lambda: v.set_compare(None if idx == 0 else choices[idx]))
        if v.comparison is not None:
            _, v.split = imgui.slider_float("divider", v.split, 0.0, 1.0, "%.2f")
            imgui.same_line()
            if imgui.small_button("swap"):
                self._guard(v.swap_sides)

    def draw_help(self, imgui) -> None:
        v = self.v
        imgui.set_next_window_pos((v.fb_size[0] / 2 - 220, 60), imgui.Cond_.appearing.value)
        opened, v.show_help = imgui.begin("Keys and mouse (F1)", True)
        if opened:
            for keys, what in KEYS_HELP:
                imgui.text(f"{keys:<18} {what}")
        imgui.end()

    def _camera_fields(self, imgui) -> None:
        """The camera's position, target and field of view, editable."""
        from app.camera import Camera

        v = self.v
        cam = v.fly.camera
        eye_changed, eye = imgui.input_float3("position", [float(x) for x in cam.eye], "%.3f")
        target_changed, target = imgui.input_float3("target", [float(x) for x in cam.target], "%.3f")
        fov_changed, fov = imgui.slider_float("fov (deg)", float(cam.fov), 10.0, 120.0, "%.1f")
        if eye_changed or target_changed or fov_changed:
            eye, target = np.asarray(eye, np.float64), np.asarray(target, np.float64)
            if np.isfinite(eye).all() and np.isfinite(target).all() and np.linalg.norm(target - eye) > 1e-9:
                new = Camera(eye, target, cam.up.copy(), float(fov), cam.near, cam.far)
                v.fly.set_camera(new)

    def _browse(self) -> None:
        """A native file dialog (imgui-bundle's portable-file-dialogs: zenity or kdialog on Linux)."""
        try:
            from imgui_bundle import portable_file_dialogs as pfd

            from scenes.loaders import EXTENSIONS

            if not pfd.settings.available():
                raise RuntimeError
            picked = pfd.open_file("Open a scene", "", ["Scenes", " ".join(f"*{e}" for e in EXTENSIONS)]).result()
        except Exception:  # noqa: BLE001 - no dialog program on this system
            self.error = "no file dialog here (install zenity or kdialog): type a path or drop a file on the window"
            return
        if picked:
            self.scene_path = picked[0]
            self.v.request_scene(picked[0])

    def _guard(self, fn) -> None:
        try:
            fn()
            self.error = ""
        except UserError as e:
            self.error = str(e)

    def _option(self, imgui, key: str) -> None:
        idle = key == "denoise" and not denoises(self.v.pass_name)  # no denoiser runs for this pass
        if idle:
            imgui.begin_disabled()
        try:
            draw_option(imgui, self.v.options, key)
        except UserError as e:
            self.error = str(e)
        finally:
            if idle:
                imgui.end_disabled()
        if key == "gbuffer" and self.v.options.get("gbuffer") == "auto":  # what auto picks here
            imgui.text_disabled(f"  auto G-buffer here: {self.v.renderer.gbuffer_source(self.v.pass_name)}")
        if key == "finish" and self.v.options.get("finish") == "auto":
            imgui.text_disabled(f"  auto finish here: {'tracer' if self.v.renderer.finishes_on_tracer() else 'gl'}")

    def draw_profiler(self, imgui) -> None:
        v = self.v
        prof = v.renderer.profiler
        imgui.set_next_window_pos((v.fb_size[0] - 370, 10), imgui.Cond_.first_use_ever.value)
        imgui.set_next_window_size((360, 300), imgui.Cond_.first_use_ever.value)
        imgui.begin("Profiler (P)")
        keep_on_screen(imgui)
        shown = v.main.shown_fps()
        ui = 1000.0 / max(np.mean(v.frame_times) if v.frame_times else 1.0, 1e-6)
        if shown > 0:
            imgui.text(f"images shown: {shown:.1f} fps ({1000.0 / shown:.1f} ms)")
        else:
            imgui.text("images shown: none new (up to date)" if v.main.shown else
                       "images shown: none yet")
        imgui.text_disabled(f"UI loop: {ui:.0f} fps")
        if v.frame_times:
            imgui.plot_lines("##frametime", np.asarray(v.frame_times, np.float32), graph_size=(300, 50))
        if imgui.begin_table("passes", 4):
            for k, h in enumerate(("pass", "kind", "last ms", "avg ms")):
                imgui.table_setup_column(h, imgui.TableColumnFlags_.width_stretch.value, 2.2 if k == 0 else 1.0)
            imgui.table_headers_row()
            rows = sorted(prof.finished.items(), key=lambda item: not item[0].startswith(v.pass_name))
            for name, ms in rows:  # the passes of the last finished frame only, the selected pass first
                imgui.table_next_row()
                for col, text in enumerate((name, prof.kind.get(name, ""), f"{ms:.2f}",
                                            f"{prof.average(name):.2f}")):
                    imgui.table_set_column_index(col)
                    imgui.text(text)
            imgui.end_table()
        gpu = sum(ms for name, ms in prof.finished.items() if prof.kind.get(name) == "gpu")
        if gpu > 0:  # timer queries and a GPU backend's timestamps; the rest of a frame is the host's
            imgui.text(f"GPU work: {gpu:.2f} ms of the last frame")
        rays = prof.finished_counters.get("rays", 0)
        if rays:
            ms = sum(prof.finished.values())  # every pass of the last finished frame
            imgui.text(f"{rays / 1e6:.2f} Mrays/frame, {rays / max(ms, 1e-6) / 1e3:.2f} Mrays/s")
        if v.future is not None:
            imgui.text_colored((1.0, 0.8, 0.3, 1.0), "tracing the next frame...")
        imgui.end()

