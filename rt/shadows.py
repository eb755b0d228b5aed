"""Ray-traced shadows: a shadow ray to every light per pixel (`all`), or to one light per
pixel chosen by its contribution there (`one`, unbiased: accumulates to `all`).
Backends: rt/embree/shadows.py."""
from __future__ import annotations

from dataclasses import dataclass

from core.options import opt, register_group
from rt.pass_base import SPECULAR, RtPass


@dataclass
class ShadowsOptions:
    lights: str = opt("all", "shadow rays to all lights per pixel, or to one chosen light", choices=("all", "one"))
    greyscale: bool = opt(False, "show light and shadow only (albedo = 1, no emission)")


register_group("shadows", ShadowsOptions)


class ShadowsPass(RtPass):
    name = "shadows"
    options = ShadowsOptions
    writes = ("radiance", "rt_direct", SPECULAR)
    stream = 1
    aux_channels = 3

    @classmethod
    def parameters(cls, opts) -> dict:
        return {"one": opts.get("shadows.lights") == "one", "greyscale": opts.get("shadows.greyscale")}
