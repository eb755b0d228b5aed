"""Ray-traced shadows: a shadow ray to every light per pixel (`all`), or to one light per
pixel chosen by its contribution there (`one`, unbiased: accumulates to `all`)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from app.options import opt, register_group
from rt import gather, scratch
from rt.shading import direct_all, direct_one


@dataclass
class ShadowsOptions:
    lights: str = opt("all", "shadow rays to all lights per pixel, or to one chosen light", choices=("all", "one"))
    greyscale: bool = opt(False, "show light and shadow only (albedo = 1, no emission)")


register_group("shadows", ShadowsOptions)


def direct_irradiance(cf, shadowed: bool = True) -> np.ndarray:
    """Irradiance x cos at a chunk's pixels, per shadows.lights (a scratch buffer: valid until
    this thread's next call)."""
    estimator = direct_all if cf.options.get("shadows.lights") == "all" else direct_one
    out = scratch.buffer("shadows.direct", (len(cf.s), 3))
    return estimator(cf.data, cf.tracer, cf.s, cf.rng(1), shadowed, out=out, G=cf.soa)


class ShadowsPass:
    name = "shadows"
    reads = ("gbuffer",)
    writes = ("radiance", "rt_direct")

    def reset(self) -> None:
        pass

    def execute(self, rf) -> dict:
        out, direct = rf.background(), rf.image()
        grey = rf.options.get("shadows.greyscale")

        def work(cf):
            e = direct_irradiance(cf)
            gather.write_lit(out, cf.idx, cf.s.emissive, cf.s.albedo, e, None, grey)
            cf.put(direct, e)

        rf.for_chunks(work, streams=(1,))
        return {"radiance": out, "rt_direct": direct}
