"""Ray-traced global illumination: direct light at the primary hit (shadowed or not, the
study's two modes) plus `rays_per_pixel` cosine-weighted bounce rays, each shaded at its hit
with one light sample and a shadow ray; `bounces` > 1 continues the path.

Light from emitters reaches bounce hits through their light samples (emissive triangles are
lights), so a bounce ray that happens to hit an emitter does not add its emission again."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from app.options import opt, register_group
from rt import gather, raygen, scratch
from rt.shading import direct_one, empty_surface


@dataclass
class GIOptions:
    rays_per_pixel: int = opt(1, "bounce rays per pixel per frame", 1, 64)
    shadows: bool = opt(True, "shadow rays for direct light (false: unshadowed, the study's cheap mode)")
    bounces: int = opt(1, "indirect bounces (the study used 1)", 1, 8)


register_group("gi", GIOptions)


def incoming_indirect(cf, s, rng, bounces: int, shadowed: bool, depth: int = 0, G=None) -> np.ndarray:
    """One-sample estimate of the radiance arriving along a cosine-sampled direction, per point
    of s (a scratch buffer of this depth: valid until this thread's next call at this depth).
    Every step runs even when no ray hits, so each pixel draws the same numbers however the
    frame is chunked. G: s.soa() if at hand."""
    n, name = len(s), f"gi{depth}"
    out = scratch.buffer(name + ".out", (n, 3))
    out.fill(0)
    o, d, _, owner = scratch.rays(name, n)
    G = s.soa(name + ".soa") if G is None else G
    m = raygen.hemisphere_live(*G, rng.key, rng.reserve(2), cf.data.eps, cf.data.far, o, d, _, owner, 0,
                               raygen.NOT_TRACED)
    hits = cf.tracer.intersect(o[:m], d[:m])  # rays below the true surface carry nothing
    sel = scratch.buffer(name + ".sel", (m,), np.int64)
    k = gather.split_hits(hits.prim, m, d, owner, out, *gather.env_args(cf.environment), sel)
    sel = sel[:k]
    sh = cf.data.surface(hits, d, o, sel=sel, out=empty_surface(k, name + ".hit"))
    keys = scratch.buffer(name + ".keys", (k,), np.uint64)
    gather.gather_keys(rng.key, owner, sel, k, keys)
    hrng = rng.with_keys(keys)
    hg = sh.soa(name + ".hit.soa")
    direct = direct_one(cf.data, cf.tracer, sh, hrng, shadowed, out=scratch.buffer(name + ".direct", (k, 3)), G=hg)
    inner = incoming_indirect(cf, sh, hrng, bounces - 1, shadowed, depth + 1, hg) if bounces > 1 else None
    gather.add_bounce(out, owner, sel, k, sh.albedo, direct, inner)
    return out


def indirect_light(cf, s, rng, G=None) -> np.ndarray:
    """Mean incoming indirect radiance over gi.rays_per_pixel rays (albedo x this = outgoing)."""
    rays = cf.options.get("gi.rays_per_pixel")
    shadowed = cf.options.get("gi.shadows")
    bounces = cf.options.get("gi.bounces")
    total = np.zeros((len(s), 3), np.float32)
    for _ in range(rays):
        total += incoming_indirect(cf, s, rng, bounces, shadowed, G=G)
    return total / np.float32(rays)


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
            G = cf.soa
            direct = direct_one(cf.data, cf.tracer, s, rng, shadowed, out=scratch.buffer("gi.direct", (len(s), 3)), G=G)
            indirect = indirect_light(cf, s, rng, G)
            gather.write_lit(out, cf.idx, s.emissive, s.albedo, direct, indirect, False)
            cf.put(indirect_image, indirect)

        rf.for_chunks(work, streams=(4,))
        return {"radiance": out, "rt_indirect": indirect_image}
