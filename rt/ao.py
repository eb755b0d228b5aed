"""Ray-traced ambient occlusion: cosine-weighted rays of length `ao.radius`; AO is the fraction
that escape (1 = fully open). Backends: rt/embree/ao.py."""
from __future__ import annotations

from dataclasses import dataclass

from core.options import opt, register_group
from rt.pass_base import RtPass


@dataclass
class AOOptions:
    radius: float = opt(1.0, "length of the occlusion rays (m)", 1e-4, 1e8)
    rays_per_pixel: int = opt(1, "occlusion rays per pixel per frame", 1, 64)
    greyscale: bool = opt(True, "show AO alone; false multiplies it with the albedo")


register_group("ao", AOOptions)


class AOPass(RtPass):
    name = "ao"
    options = AOOptions
    writes = ("radiance", "rt_ao")
    stream = 2
    lights = False
    # one 5 x 5 iteration: the temporal average of a binary visibility converges within frames,
    # and wider filters blur contact shadows that 16 raw frames resolve (bench ao_1+svgf at
    # 320x180: arcade FLIP 0.0334 with 3, 0.0260 with 1, 16 raw frames 0.0288)
    svgf_iterations = 1

    @classmethod
    def parameters(cls, opts) -> dict:
        return {"rays": opts.get("ao.rays_per_pixel"), "radius": opts.get("ao.radius"),
                "greyscale": opts.get("ao.greyscale")}

    @classmethod
    def radiance_terms(cls, opts) -> tuple[bool, bool]:
        """No emission; the albedo only where not greyscale (AO alone is no material's)."""
        return not opts.get("ao.greyscale"), False
