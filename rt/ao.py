"""Ray-traced ambient occlusion: cosine-weighted rays of length `radius`; AO is the fraction
that escape (1 = fully open)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from app.options import opt, register_group
from rt import kernels
from rt.shading import hemisphere


@dataclass
class AOOptions:
    radius: float = opt(1.0, "length of the occlusion rays (m)", 1e-4, 1e4)
    rays_per_pixel: int = opt(1, "occlusion rays per pixel per frame", 1, 64)
    greyscale: bool = opt(True, "show AO alone; false multiplies it with the albedo")


register_group("ao", AOOptions)


def ambient_occlusion(rf) -> np.ndarray:
    s = rf.gb.surface
    rays = rf.options.get("ao.rays_per_pixel")
    radius = np.float32(rf.options.get("ao.radius"))
    rng = rf.rng(2)
    open_count = np.zeros(len(s), np.float32)
    for _ in range(rays):
        o, d, above = hemisphere(rf.data, s, rng)
        idx = kernels.compact_valid(above, o, d)  # a direction below the true surface counts as occluded
        if idx.size:
            kernels.add_open(open_count, idx, rf.tracer.occluded(o[:idx.size], d[:idx.size], radius))
    return open_count / np.float32(rays)


class AOPass:
    name = "ao"
    reads = ("gbuffer",)
    writes = ("radiance", "rt_ao")

    def reset(self) -> None:
        pass

    def execute(self, rf) -> dict:
        ao = ambient_occlusion(rf)
        out = rf.background()
        s = rf.gb.surface
        albedo = np.ones_like(s.albedo) if rf.options.get("ao.greyscale") else s.albedo
        zero = np.zeros_like(s.albedo)
        kernels.scatter_lit(out, rf.gb.index, zero, albedo, np.float32(1.0), np.repeat(ao[:, None], 3, 1), zero)
        return {"radiance": out, "rt_ao": rf.full(ao, fill=1.0)}
