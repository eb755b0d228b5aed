"""A worker of the sweep (app/sweep.py): it runs units, each one measurement of app/measure.py
on a renderer of its scene, and keeps the renderers of the last scenes it used between units.
The same worker serves `rtlab bench` in its own process and each Ray worker process of
`--cluster` (app/cluster.py); a unit and its result are plain data (dicts, numpy arrays), so
they travel between machines.

Units (the "kind" key):
- time: one configuration's timed frames -> its result row;
- reference: a batch of the reference's frames -> their sum (app/measure.reference_batch);
- quality: one configuration's effect in the forward frame, one frame and accumulated;
- denoise: a one-sample configuration's denoised frames against its converged pass;
- path: the scripted camera path.
Every result carries "worker": which machine measured it (host, Ray node, a label of the
machine's kind: CPU, GL renderer, ray-tracing device) and the BVH build time where the unit
built its renderer."""
from __future__ import annotations

import os
import socket
import time
from collections import OrderedDict

from app.camera import Camera, parse_camera
from app.gl_context import check_frame_size, create_headless_context
from app.machine import machine_info, machine_label
from app.options import Options
from app.renderer import Renderer

KEEP_SCENES = 2  # renderers a cluster's worker keeps (a BVH and the scene's GPU copy each)


class Worker:
    def __init__(self, settings: dict, scenes: dict | None = None, node: str = "local", keep: int = KEEP_SCENES):
        """settings: the bench's (app/bench.py: worker_settings); scenes: already loaded scenes by
        spec (the bench's own process, which measures one scene at a time and keeps one
        renderer), others are opened here."""
        self.settings, self.loaded, self.node, self.keep = settings, dict(scenes or {}), node, keep
        self.ctx = None
        self.kept: OrderedDict[str, tuple] = OrderedDict()  # spec -> (scene, renderer, camera, info)
        self.machine = None

    def context(self):
        if self.ctx is None:
            self.ctx = create_headless_context()
            self.machine = machine_info(self.ctx)
        return self.ctx

    def renderer(self, spec: str) -> tuple:
        """(scene, renderer, camera, build seconds or None when kept from an earlier unit)."""
        if spec in self.kept:
            self.kept.move_to_end(spec)
            scene, renderer, camera, _ = self.kept[spec]
            return scene, renderer, camera, None
        from app.loading import open_scene

        while self.kept and len(self.kept) >= self.keep:  # the least recently used goes before another is made
            _, (_, old, _, _) = self.kept.popitem(last=False)
            old.release()
        ctx = self.context()
        check_frame_size(ctx, *self.settings["size"])
        scene = self.loaded.get(spec) or open_scene(spec)
        cam = self.settings.get("camera")
        camera = parse_camera(cam, scene) if cam else Camera.from_view(scene.default_view(), scene.diagonal)
        options = Options()
        options.apply(list(self.settings["options"]))
        renderer = Renderer(ctx, scene, options, prefetch=True)
        t0 = time.perf_counter()
        backend = renderer.ray_tracing()
        build_s = time.perf_counter() - t0
        tracer = {"name": backend.name, "device": getattr(backend, "adapter", "CPU")}
        self.kept[spec] = (scene, renderer, camera, tracer)
        return scene, renderer, camera, build_s

    def about(self, spec: str, build_s) -> dict:
        tracer = self.kept[spec][3]
        return {"host": socket.gethostname(), "node": self.node, "tracer": tracer, "bvh_build_s": build_s,
                "machine": self.machine, "kind": machine_label(self.machine, tracer)}

    def run(self, unit: dict, threads: int | None = None) -> dict:
        from app import measure

        t0 = time.perf_counter()
        spec, kind, st = unit["scene"], unit["kind"], self.settings
        scene, renderer, camera, build_s = self.renderer(spec)
        if threads:
            _set_threads(renderer, threads)
        base = tuple(st["options"])
        size, qsize = tuple(st["size"]), tuple(st["quality_size"])
        out: dict = {"worker": self.about(spec, build_s)}
        if kind == "time":
            out["row"] = measure.time_config(self.ctx, renderer, camera, size, unit["config"], st["warmup"],
                                             st["frames"], st["seconds"], base)
        elif kind == "reference":
            out["sum"] = measure.reference_batch(renderer, camera, qsize, unit["first"], unit["count"],
                                                 base).astype("float32")
        elif kind == "quality":
            out["single"], out["accumulated"] = measure.quality_images(renderer, camera, qsize, unit["config"],
                                                                       st["quality_frames"], base)
        elif kind == "denoise":
            out["images"] = measure.denoised_images(renderer, camera, qsize, unit["config"], unit["denoisers"],
                                                    st["reference_frames"], base)
        elif kind == "path":
            out["path"] = measure.measure_path(renderer, camera, qsize, scene.diagonal, st["path_frames"],
                                               max(st["reference_frames"] // 4, 4), base)
        else:
            raise ValueError(f"unknown unit {kind!r}")
        out["seconds"] = time.perf_counter() - t0  # the unit's time on its worker, its renderer's build included
        return out

    def release(self) -> None:
        while self.kept:
            _, (_, renderer, _, _) = self.kept.popitem()
            renderer.release()


def _set_threads(renderer: Renderer, threads: int) -> None:
    """Embree's and numba's threads: the CPUs a cluster task was given, not every core of its node."""
    import numba

    backend = renderer.ray_tracing()
    if getattr(backend, "tracer", None) is not None and hasattr(backend.tracer, "set_threads"):
        backend.tracer.set_threads(threads)
    numba.set_num_threads(max(1, min(threads, numba.config.NUMBA_NUM_THREADS)))
    os.environ["OMP_NUM_THREADS"] = str(threads)
