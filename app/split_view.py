"""The viewer's frames: a Track makes one renderer's frames without ever blocking the window
(ray-traced work on the viewer's worker thread), and the split view (`--compare`, the panel's
"compare with") puts a second Track of the same scene, camera and options right of a
draggable divider: another pass, or for `diff` the FLIP map of the main image against the
reference path tracer (app/compare.py), recomputed as either side's frames accumulate."""
from __future__ import annotations

import time
from collections import deque

import numpy as np

from app.compare import DIFF, flip_map
from app.profiler import Profiler
from app.renderer import Renderer

FLIP_INTERVAL_S = 0.5  # the diff map is recomputed at most this often (FLIP runs on the CPU)


def _only_the_view_moved(old: tuple, new: tuple) -> bool:
    """Renderer.state_of tuples that differ in the camera or size only (same scene, pass,
    options and seed)."""
    return (old[0], old[4], old[5], old[6]) == (new[0], new[4], new[5], new[6])


class Track:
    """One renderer's frames in the viewer: prepare on the GL thread, compute on the pool,
    finish on the GL thread once done, if nothing changed meanwhile."""

    def __init__(self, renderer: Renderer, pool):
        self.renderer, self.pool = renderer, pool
        self.job = self.future = None
        self.shown = False  # a frame of the current state was finished: the display image is real
        self.shown_label = ""  # "scene: pass" of the image on screen
        self.shown_times: deque = deque(maxlen=60)  # when each image on screen was finished

    def _finished(self, pass_name: str) -> None:
        self.shown = True
        self.shown_label = f"{self.renderer.scene.name}: {pass_name}"
        self.shown_times.append(time.perf_counter())

    def shown_fps(self) -> float:
        """Images finished per second over the last few (the frame rate a user sees)."""
        t = self.shown_times
        if len(t) < 2 or time.perf_counter() - t[-1] > 5.0:
            return 0.0
        return (len(t) - 1) / max(t[-1] - t[0], 1e-6)

    @property
    def busy(self) -> bool:
        return self.future is not None

    def advance(self, camera, width: int, height: int, pass_name: str, start_new: bool = True) -> None:
        r = self.renderer
        if self.future is not None:
            if not self.future.done():
                return
            job, future = self.job, self.future
            self.job = self.future = None
            future.result()  # re-raise a tracing error here
            now = r.state_of(camera, width, height, pass_name)
            if job.state == r._state and (job.state == now or _only_the_view_moved(job.state, now)):
                r.finish(job)  # while flying, frames a moment old are shown rather than none
                self._finished(pass_name)
            # else the scene, pass or an option changed while tracing: the frame is stale
        if not start_new:
            return
        job = r.prepare(camera, width, height, pass_name)
        if job is None:
            return
        if job.cpu:
            self.job, self.future = job, self.pool.submit(r.compute, job)
        else:
            r.finish(job)
            self._finished(pass_name)

    def drop(self) -> None:
        """Wait for the frame being traced and discard it (its scene or state is going away)."""
        if self.future is not None:
            try:
                self.future.result()
            except Exception:  # noqa: BLE001 - its error no longer matters
                pass
        self.job = self.future = None

    def wait(self) -> None:
        if self.future is not None:
            self.future.result()


class Comparison:
    """The right side of the split view."""

    def __init__(self, ctx, scene, options, mode: str, pool):
        self.ctx, self.mode = ctx, mode
        renderer = Renderer(ctx, scene, options, Profiler(deferred=True))
        renderer.reuse_static_frames = True
        self.track = Track(renderer, pool)
        self.flip_texture = None
        self.flip_mean: float | None = None
        self._flip_key, self._flip_time = None, 0.0

    @property
    def pass_name(self) -> str:
        return "reference" if self.mode == DIFF else self.mode

    @property
    def label(self) -> str:
        if not self.track.shown:
            return f"{self.pass_name}: tracing..."
        if self.mode != DIFF:
            return f"{self.mode}: {self.track.renderer.frame_count} frames"
        mean = "..." if self.flip_mean is None else f"{self.flip_mean:.3f}"
        return f"FLIP vs reference ({self.track.renderer.frame_count} frames): {mean}"

    def set_scene(self, scene) -> None:
        self.track.drop()
        self.track.shown = False
        self.track.renderer.set_scene(scene)
        self._flip_key = None

    def texture(self, main: Renderer):
        """What the right side shows: the pass's display image, or the diff's FLIP map."""
        r = self.track.renderer
        if r.frame is None or not self.track.shown:
            return None  # nothing finished yet: the divider's right stays empty, not stale
        if self.mode != DIFF:
            return r.frame.channels.get("display")
        if main.frame is None:
            return self.flip_texture
        key = (main.frame_count, r.frame_count, main._state, r._state)
        now = time.perf_counter()
        if key != self._flip_key and now - self._flip_time >= FLIP_INTERVAL_S:
            reference, test = r.read_display(), main.read_display()
            if reference.shape == test.shape:
                image, self.flip_mean = flip_map(reference, test)
                self._upload(image)
                self._flip_key, self._flip_time = key, now
        return self.flip_texture

    def _upload(self, image: np.ndarray) -> None:
        h, w = image.shape[:2]
        rgba = np.concatenate([image, np.full((h, w, 1), 255, np.uint8)], 2)[::-1]  # GL rows bottom first
        if self.flip_texture is None or self.flip_texture.size != (w, h):
            if self.flip_texture is not None:
                self.flip_texture.release()
            self.flip_texture = self.ctx.texture((w, h), 4, dtype="f1")
        self.flip_texture.write(np.ascontiguousarray(rgba).tobytes())

    def release(self) -> None:
        self.track.drop()
        self.track.renderer.release()
        if self.flip_texture is not None:
            self.flip_texture.release()
            self.flip_texture = None
