"""What a ray-traced pass receives: the CPU G-buffer, the tracer, the scene's shading data."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rt.gbuffer import CpuGBuffer
from rt.sampling import PixelRng
from rt.shading import SceneData
from rt.tracer import Tracer


@dataclass
class RtFrame:
    data: SceneData
    tracer: Tracer
    gb: CpuGBuffer
    environment: object  # scenes.model.Environment
    options: object  # app.options.Options
    seed: int = 0
    index: int = 0  # frame index since the last reset

    def rng(self, stream: int) -> PixelRng:
        """Per-pixel generator for the covered pixels, seeded from (seed, frame, pixel, stream)."""
        return PixelRng(self.seed, self.index, self.gb.index, stream)

    def background(self) -> np.ndarray:
        """(N,3) image holding the environment's radiance; passes fill in covered pixels."""
        out = np.zeros((self.gb.n, 3), np.float32)
        miss = ~self.gb.covered
        if miss.any() and self.environment.kind != "black":
            out[miss] = self.environment.radiance(self.gb.view_dir[miss])
        return out

    def full(self, values: np.ndarray, fill=0.0) -> np.ndarray:
        """Scatter per-covered-pixel values into a full image array."""
        from rt.kernels import scatter_rows

        out = np.full((self.gb.n,) + values.shape[1:], fill, np.float32)
        v = np.ascontiguousarray(values, np.float32)
        scatter_rows(out.reshape(self.gb.n, -1), self.gb.index, v.reshape(v.shape[0], -1))
        return out
