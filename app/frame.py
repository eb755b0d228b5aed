"""What flows through one frame: inputs, named channels, timing."""
from __future__ import annotations

from dataclasses import dataclass, field

from app.camera import Camera
from app.options import Options
from app.profiler import Profiler


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
    channels: dict = field(default_factory=dict)

    @property
    def aspect(self) -> float:
        return self.width / max(self.height, 1)

    def view_proj(self, camera: Camera | None = None):
        cam = camera or self.camera
        return cam.projection_matrix(self.aspect) @ cam.view_matrix()
