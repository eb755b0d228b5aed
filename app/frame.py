"""What flows through one frame: inputs, named channels, timing."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from app.camera import Camera
from app.profiler import Profiler
from core.options import Options
from rt.backend import FrameInputs


@dataclass
class Frame:
    ctx: object
    scene: object  # scenes.model.Scene
    gpu: object  # app.raster.gpu_scene.GpuScene
    camera: Camera
    prev_camera: Camera
    width: int
    height: int
    options: Options
    profiler: Profiler
    environment: object  # scenes.model.Environment in effect (scene's or env= option)
    index: int = 0  # frames since the last reset (accumulation index)
    seed: int = 0
    mode: str = "forward"  # the pass mode (--pass): app/graph.py
    backend: object = None  # rt.backend.Backend of the ray-traced passes, when the mode has any
    channels: dict = field(default_factory=dict)  # channel name -> texture, image or value
    wanted: frozenset = frozenset()  # the channels the graph reads from the pass now running
    jitter: tuple = (0.0, 0.0)  # subpixel offset of this frame's samples (pixels: right, down; app/camera.py)
    moved: bool = False  # the camera moved since the last frame, whose accumulation goes on (reproject)
    interop: object = None  # app.raster.interop.Interop: memory shared with the backend's device, or None

    @property
    def aspect(self) -> float:
        return self.width / max(self.height, 1)

    def view_proj(self, camera: Camera | None = None):
        """The camera's view-projection; this frame's own (camera None) moved by the jitter."""
        cam = camera or self.camera
        m = cam.projection_matrix(self.aspect) @ cam.view_matrix()
        if camera is None:
            m = self.jitter_matrix() @ m
        return m

    def jitter_ndc(self) -> tuple[float, float]:
        """How far the jittered projection moves the image, in normalised device coordinates (y
        up): against the jitter, so that each pixel's centre sees what lies at its centre + jitter."""
        return -2.0 * self.jitter[0] / self.width, 2.0 * self.jitter[1] / max(self.height, 1)

    def jitter_matrix(self) -> np.ndarray:
        """Clip-space shift by jitter_ndc: x' = x + jx w, so x'/w = x/w + jx."""
        m = np.eye(4)
        m[0, 3], m[1, 3] = self.jitter_ndc()
        return m

    def backend_inputs(self, gbuffer: dict | None) -> FrameInputs:
        """This frame as a ray-tracing backend takes it (gbuffer: the packed raster G-buffer)."""
        return FrameInputs(self.camera, self.prev_camera, self.width, self.height, self.environment, self.options,
                           self.seed, self.index, gbuffer, self.jitter)
