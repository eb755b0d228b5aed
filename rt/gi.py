"""Ray-traced global illumination: direct light at the primary hit (shadowed or not, the
study's two modes) plus `rays_per_pixel` cosine-weighted bounce rays, each shaded at its hit
with one light sample and a shadow ray; `bounces` > 1 continues the path.

Light from emitters reaches bounce hits through their light samples (emissive triangles are
lights), so a bounce ray that happens to hit an emitter does not add its emission again."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from app.options import opt, register_group
from rt import kernels
from rt.shading import INV_PI, direct_one, hemisphere, trace_from


@dataclass
class GIOptions:
    rays_per_pixel: int = opt(1, "bounce rays per pixel per frame", 1, 64)
    shadows: bool = opt(True, "shadow rays for direct light (false: unshadowed, the study's cheap mode)")
    bounces: int = opt(1, "indirect bounces (the study used 1)", 1, 8)


register_group("gi", GIOptions)


def incoming_indirect(rf, s, rng, bounces: int, shadowed: bool) -> np.ndarray:
    """One-sample estimate of the radiance arriving along a cosine-sampled direction."""
    o, d, valid = hemisphere(rf.data, s, rng)
    out = np.zeros((len(s), 3), np.float32)
    above = kernels.compact_valid(valid, o, d)  # rays below the true surface carry nothing
    m = above.size
    if not m:
        return out
    hit, sh, miss = trace_from(rf.data, rf.tracer, None, d[:m], o[:m])
    if miss.size and rf.environment.kind != "black":
        out[above[miss]] = rf.environment.radiance(d[miss])
    if hit.size:
        hrng = rng.subset(above[hit])
        radiance = sh.albedo * INV_PI * direct_one(rf.data, rf.tracer, sh, hrng, shadowed)
        if bounces > 1:
            radiance += sh.albedo * incoming_indirect(rf, sh, hrng, bounces - 1, shadowed)
        out[above[hit]] = radiance
    return out


def indirect_light(rf, s, rng) -> np.ndarray:
    """Mean incoming indirect radiance over gi.rays_per_pixel rays (albedo x this = outgoing)."""
    rays = rf.options.get("gi.rays_per_pixel")
    shadowed = rf.options.get("gi.shadows")
    bounces = rf.options.get("gi.bounces")
    total = np.zeros((len(s), 3), np.float32)
    for _ in range(rays):
        total += incoming_indirect(rf, s, rng, bounces, shadowed)
    return total / rays


class GIPass:
    name = "gi"
    reads = ("gbuffer",)
    writes = ("radiance", "rt_indirect")

    def reset(self) -> None:
        pass

    def execute(self, rf) -> dict:
        s = rf.gb.surface
        rng = rf.rng(4)
        direct = direct_one(rf.data, rf.tracer, s, rng, rf.options.get("gi.shadows"))
        indirect = indirect_light(rf, s, rng)
        out = rf.background()
        kernels.scatter_lit(out, rf.gb.index, s.emissive, s.albedo, INV_PI, direct, indirect)
        return {"radiance": out, "rt_indirect": rf.full(indirect)}
