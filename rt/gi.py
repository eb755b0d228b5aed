"""Ray-traced global illumination: direct light at the primary hit (shadowed or not, the
study's two modes) plus `gi.rays_per_pixel` cosine-weighted bounce rays, each shaded at its hit
with one light sample and a shadow ray; `gi.bounces` > 1 continues the path.
Backends: rt/embree/gi.py."""
from __future__ import annotations

from dataclasses import dataclass

from core.options import opt, register_group
from rt.pass_base import SPECULAR, RtPass


@dataclass
class GIOptions:
    rays_per_pixel: int = opt(1, "bounce rays per pixel per frame", 1, 64)
    shadows: bool = opt(True, "shadow rays for direct light (false: unshadowed, the study's cheap mode)")
    bounces: int = opt(1, "indirect bounces (the study used 1)", 1, 8)


register_group("gi", GIOptions)


class GIPass(RtPass):
    name = "gi"
    options = GIOptions
    writes = ("radiance", "rt_indirect", SPECULAR)
    stream = 4
    aux_channels = 3

    @classmethod
    def parameters(cls, opts) -> dict:
        return {"rays": opts.get("gi.rays_per_pixel"), "bounces": opts.get("gi.bounces"),
                "shadows": opts.get("gi.shadows")}
