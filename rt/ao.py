"""Ray-traced ambient occlusion: cosine-weighted rays of length `radius`; AO is the fraction
that escape (1 = fully open)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from app.options import opt, register_group
from rt import gather, raygen, scratch


@dataclass
class AOOptions:
    radius: float = opt(1.0, "length of the occlusion rays (m)", 1e-4, 1e4)
    rays_per_pixel: int = opt(1, "occlusion rays per pixel per frame", 1, 64)
    greyscale: bool = opt(True, "show AO alone; false multiplies it with the albedo")


register_group("ao", AOOptions)


def ambient_occlusion(cf) -> np.ndarray:
    """How many of a chunk's ao.rays_per_pixel occlusion rays escape, per pixel (a scratch
    buffer: valid until this thread's next call)."""
    s = cf.s
    rays = cf.options.get("ao.rays_per_pixel")
    radius = np.float32(cf.options.get("ao.radius"))
    rng = cf.rng(2)
    n = len(s)
    open_count = scratch.buffer("ao.count", (n,))
    open_count.fill(0)
    o, d, t, idx = scratch.rays("ao", n)
    G = cf.soa
    scene = cf.tracer.inline_scene()  # traced (and counted) as they are made, or after
    acc = open_count.reshape(n, 1)
    for _ in range(rays):
        m = raygen.hemisphere_live(*G, rng.key, rng.reserve(2), cf.data.eps, radius, o, d, t, idx, scene, acc)
        if scene:
            cf.tracer.rays_traced += m
            continue
        blocked = cf.tracer.occluded(o[:m], d[:m], t[:m]) if m else np.zeros(0, np.bool_)
        raygen.add_open(open_count, idx, blocked, m)  # rays below the true surface count as occluded
    return open_count  # of ao.rays_per_pixel


class AOPass:
    name = "ao"
    reads = ("gbuffer",)
    writes = ("radiance", "rt_ao")

    def reset(self) -> None:
        pass

    def execute(self, rf) -> dict:
        out, ao_image = rf.background(), rf.image(1, fill=1.0)
        grey, rays = rf.options.get("ao.greyscale"), rf.options.get("ao.rays_per_pixel")

        def work(cf):
            gather.write_ao(out, ao_image, cf.idx, ambient_occlusion(cf), rays, cf.s.albedo, grey)

        rf.for_chunks(work, streams=(2,))
        return {"radiance": out, "rt_ao": ao_image}
