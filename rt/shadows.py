"""Ray-traced shadows: a shadow ray to every light per pixel (`all`), or to one light per
pixel chosen by its contribution there (`one`, unbiased: accumulates to `all`)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from app.options import opt, register_group
from rt import kernels
from rt.shading import INV_PI, direct_all, direct_one


@dataclass
class ShadowsOptions:
    lights: str = opt("all", "shadow rays to all lights per pixel, or to one chosen light", choices=("all", "one"))
    greyscale: bool = opt(False, "show light and shadow only (albedo = 1, no emission)")


register_group("shadows", ShadowsOptions)


def direct_irradiance(cf, shadowed: bool = True) -> np.ndarray:
    """Irradiance x cos at a chunk's pixels, per shadows.lights."""
    estimator = direct_all if cf.options.get("shadows.lights") == "all" else direct_one
    return estimator(cf.data, cf.tracer, cf.s, cf.rng(1), shadowed)


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
            s = cf.s
            e = direct_irradiance(cf)
            zero = np.zeros_like(e)
            if grey:
                kernels.scatter_lit(out, cf.idx, zero, np.ones_like(e), INV_PI, e, zero)
            else:
                kernels.scatter_lit(out, cf.idx, s.emissive, s.albedo, INV_PI, e, zero)
            cf.put(direct, e)

        rf.for_chunks(work)
        return {"radiance": out, "rt_direct": direct}
