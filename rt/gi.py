"""Ray-traced global illumination: direct light at the primary hit (shadowed or not, the
study's two modes) plus `rays_per_pixel` cosine-weighted bounce rays, each shaded at its hit
with one light sample and a shadow ray; `bounces` > 1 continues the path.

Light from emitters reaches bounce hits through their light samples (emissive triangles are
lights), so a bounce ray that happens to hit an emitter does not add its emission again."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from app.options import opt, register_group
from rt import kernels, raygen, scratch
from rt.shading import INV_PI, direct_one, trace_from


@dataclass
class GIOptions:
    rays_per_pixel: int = opt(1, "bounce rays per pixel per frame", 1, 64)
    shadows: bool = opt(True, "shadow rays for direct light (false: unshadowed, the study's cheap mode)")
    bounces: int = opt(1, "indirect bounces (the study used 1)", 1, 8)


register_group("gi", GIOptions)


def incoming_indirect(cf, s, rng, bounces: int, shadowed: bool, depth: int = 0) -> np.ndarray:
    """One-sample estimate of the radiance arriving along a cosine-sampled direction."""
    out = np.zeros((len(s), 3), np.float32)
    o, d, _, idx = scratch.rays(f"gi{depth}", len(s))
    m = raygen.hemisphere_live(s.p, s.n, s.ng, rng.key, rng.reserve(2), cf.data.eps, cf.data.far, o, d, _, idx)
    above = idx[:m]  # rays below the true surface carry nothing
    hit, sh, miss = trace_from(cf.data, cf.tracer, None, d[:m], o[:m])
    if miss.size and cf.environment.kind != "black":
        out[above[miss]] = cf.environment.radiance(d[miss])
    # every step runs even for no hits, so each pixel draws the same numbers however it is chunked
    hrng = rng.subset(above[hit])
    radiance = sh.albedo * INV_PI * direct_one(cf.data, cf.tracer, sh, hrng, shadowed)
    if bounces > 1:
        radiance += sh.albedo * incoming_indirect(cf, sh, hrng, bounces - 1, shadowed, depth + 1)
    out[above[hit]] = radiance
    return out


def indirect_light(cf, s, rng) -> np.ndarray:
    """Mean incoming indirect radiance over gi.rays_per_pixel rays (albedo x this = outgoing)."""
    rays = cf.options.get("gi.rays_per_pixel")
    shadowed = cf.options.get("gi.shadows")
    bounces = cf.options.get("gi.bounces")
    total = np.zeros((len(s), 3), np.float32)
    for _ in range(rays):
        total += incoming_indirect(cf, s, rng, bounces, shadowed)
    return total / rays


class GIPass:
    name = "gi"
    reads = ("gbuffer",)
    writes = ("radiance", "rt_indirect")

    def reset(self) -> None:
        pass

    def execute(self, rf) -> dict:
        out, indirect_image = rf.background(), rf.image()
        shadowed = rf.options.get("gi.shadows")

        def work(cf):
            s, rng = cf.s, cf.rng(4)
            direct = direct_one(cf.data, cf.tracer, s, rng, shadowed)
            indirect = indirect_light(cf, s, rng)
            kernels.scatter_lit(out, cf.idx, s.emissive, s.albedo, INV_PI, direct, indirect)
            cf.put(indirect_image, indirect)

        rf.for_chunks(work)
        return {"radiance": out, "rt_indirect": indirect_image}
