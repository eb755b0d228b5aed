"""What flows through one frame: inputs, named channels, timing."""
from __future__ import annotations

from dataclasses import dataclass, field

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

    @property
    def aspect(self) -> float:
        return self.width / max(self.height, 1)

    def view_proj(self, camera: Camera | None = None):
        cam = camera or self.camera
        return cam.projection_matrix(self.aspect) @ cam.view_matrix()

    def backend_inputs(self, gbuffer: dict | None) -> FrameInputs:
        """This frame as a ray-tracing backend takes it (gbuffer: the packed raster G-buffer)."""
        return FrameInputs(self.camera, self.prev_camera, self.width, self.height, self.environment, self.options,
                           self.seed, self.index, gbuffer)
