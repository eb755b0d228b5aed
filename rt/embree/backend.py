"""The Embree backend behind rt.backend.Backend: the scene's BVH and shading arrays, the CPU
G-buffer of each frame, and one whole-frame kernel per effect: the module rt/embree/<effect>.py,
whose trace(rf) makes the effect's images (ao.py, shadows.py, gi.py, reflections.py,
reference.py; traces() finds them by the effects' names). Images are numpy arrays; to_host
hands them on as they are."""
from __future__ import annotations

import importlib
from pathlib import Path

import numpy as np

from rt.backend import AUX_CHANNEL, Backend, FrameInputs
from rt.effects import EFFECTS, PLUGINS
from rt.embree.alpha import AlphaData
from rt.embree.frame import RtFrame
from rt.embree.gbuffer import from_raster, trace_primary
from rt.embree.shading import SceneData
from rt.embree.tracer import EmbreeTracer
from rt.pass_base import SPECULAR


def trace_function(effect: str):
    """The effect's trace(rf): an RTLAB_EFFECTS module's embree_trace, else rt/embree/<effect>.py's."""
    plugin = getattr(PLUGINS.get(effect), "embree_trace", None)
    return plugin if plugin is not None else importlib.import_module(f"rt.embree.{effect}").trace


def traces() -> dict:
    """Each effect this backend traces (those with a module rt/embree/<effect>.py, or from
    RTLAB_EFFECTS with an embree_trace): its trace."""
    here = Path(__file__).parent
    return {e: trace_function(e) for e in EFFECTS
            if hasattr(PLUGINS.get(e), "embree_trace") or (here / f"{e}.py").is_file()}


class EmbreeBackend(Backend):
    name = "embree"

    def __init__(self, threads: int | None = None):
        self.threads = threads
        self.data: SceneData | None = None  # the scene in the kernels' flat arrays
        self.tracer: EmbreeTracer | None = None  # the BVH and the threads that trace
        self.frame: RtFrame | None = None  # the current frame (begin_frame)
        self.inputs: FrameInputs | None = None
        # full-image outputs kept from frame to frame: fresh arrays cost a page fault per page
        self._buffers: dict = {}

    @property
    def rays_traced(self) -> int:
        return self.tracer.rays_traced if self.tracer is not None else 0

    def set_scene(self, scene) -> None:
        self.close()
        self.data = SceneData(scene)
        alpha = AlphaData(self.data) if self.data.has_alpha else None  # masked materials: the any-hit filter
        self.tracer = EmbreeTracer(scene.positions, scene.indices, threads=self.threads, alpha=alpha)

    def begin_frame(self, inputs: FrameInputs) -> None:
        self.inputs = inputs
        if inputs.gbuffer is not None:
            gb = from_raster(inputs.gbuffer, inputs.camera, inputs.width, inputs.height, reuse=True,
                             jitter=inputs.jitter)
        else:
            gb = trace_primary(self.data, self.tracer, inputs.camera, inputs.width, inputs.height, reuse=True,
                               jitter=inputs.jitter)
        self.frame = RtFrame(self.data, self.tracer, gb, inputs.environment, inputs.options, inputs.seed,
                             inputs.index, self._buffers)

    def trace(self, effect: str, channels: tuple[str, ...] = ("radiance",)) -> dict:
        rf = self.frame
        rf.aux = AUX_CHANNEL.get(effect) in channels  # the effect's second image only when asked
        rf.specular = SPECULAR in channels
        result = trace_function(effect)(rf)
        return {c: result[c] for c in channels}

    def gbuffer_view(self, channel: str) -> np.ndarray:
        rf, inputs = self.frame, self.inputs
        gb, s = rf.gb, rf.gb.surface
        values = {"albedo": s.albedo, "normal": s.n, "position": s.p, "roughness": s.roughness[:, None],
                  "metallic": s.metallic[:, None],
                  "emissive": s.emissive, "depth": gb.depth[gb.index][:, None]}
        if channel == "motion":
            values["motion"] = inputs.motion(s.p)
        v = values[channel]
        return rf.full(np.broadcast_to(v, (len(s), 3)) if v.shape[1] == 1 else v)

    def present(self, radiance, weight: float, exposure: float, display=None, oidn=None) -> tuple:
        """The end of the frame on the tracer's threads (rt/embree/present.py), where option
        finish puts it (Renderer._presents): the running mean of radiance (weight: 1 / (frames so
        far + 1), 1 restarts it, 0 keeps it) and its tone-mapped 8-bit RGBA, rows bottom-up as GL
        stores a texture. Returns both, the mean (width x height, 3) top row first; valid until
        the next frame's present."""
        from rt.embree.present import present

        w, h = self.inputs.width, self.inputs.height
        mean = self._buffers.get("present.mean")
        if mean is None or mean.shape != (w * h, 3):
            mean = self._buffers["present.mean"] = np.zeros((w * h, 3), np.float32)
            weight = 1.0  # no mean of this size to go on from
        shown = self._buffers.get("present.display")
        if shown is None or shown.shape != (h, w, 4):
            shown = self._buffers["present.display"] = np.empty((h, w, 4), np.uint8)
        present(self.tracer, np.ascontiguousarray(radiance, np.float32), mean, shown, w, h, weight, exposure)
        return mean, shown

    def to_host(self, image) -> np.ndarray:
        return image

    def close(self) -> None:
        if self.tracer is not None:
            self.tracer.close()
        if self.data is not None:  # SceneData and its LightSet point at each other: break the cycle,
            self.data.lights = None  # so the scene's arrays go now, not at the next full collection
            self.data._kernel_scene = None
        self.tracer, self.data, self.frame = None, None, None
