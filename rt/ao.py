"""Ray-traced ambient occlusion: cosine-weighted rays of length `radius`; AO is the fraction
that escape (1 = fully open)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from app.options import opt, register_group
from rt import kernels


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
    n = len(s)
    open_count = np.zeros(n, np.float32)
    o, d = np.empty((n, 3), np.float32), np.empty((n, 3), np.float32)
    valid = np.empty(n, np.bool_)
    tmax = np.full(n, radius, np.float32)
    live = {}
    for _ in range(rays):
        dim = rng.reserve(2)

        def make(c, dim=dim):
            kernels.hemisphere_rays_chunk(s.p[c], s.n[c], s.ng[c], rng.key[c], dim, rf.data.eps, o[c], d[c], valid[c])
            idx = live[c.start] = kernels.compact_valid(valid[c], o[c], d[c])  # below the surface: occluded
            return o[c][:idx.size], d[c][:idx.size], tmax[c][:idx.size].copy()

        def use(c, blocked):
            kernels.add_open_chunk(open_count[c], live[c.start], blocked)

        rf.tracer.occlusion_pipeline(n, make, use)
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
