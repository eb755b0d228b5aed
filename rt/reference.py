"""Reference path tracer: the ground truth for quality metrics.

Multi-bounce, diffuse + mirror-like specular consistent with the passes: surfaces smoother
than `reflections.roughness_threshold` reflect with Schlick's Fresnel probability and are
diffuse otherwise; next-event estimation (one light sample + shadow ray) at diffuse vertices,
combined with the cosine-weighted bounce's hits on emitters by multiple importance sampling
(`reference.mis`, the power heuristic); an environment map sampled by importance
too (rt/environment.py EnvDistribution: its luminance), weighted the same way against the
bounce that escapes to it; emission counted at the camera and after mirror bounces (where NEE
cannot reach); Russian roulette after `reference.rr_start` bounces.
Backends: rt/embree/reference.py, shaders/rt/reference.slang."""
from __future__ import annotations

from dataclasses import dataclass

from core.options import opt, register_group
from rt.pass_base import RtPass


@dataclass
class ReferenceOptions:
    max_bounces: int = opt(8, "indirect bounces before a path stops", 1, 64)
    rr_start: int = opt(3, "Russian roulette from this bounce on", 1, 64)
    mis: bool = opt(True, "combine light sampling and the bounces' hits on emitters by multiple importance "
                    "sampling (power heuristic: the cosine's density, or with brdf=ggx both lobes'), and sample "
                    "the environment by importance against the bounces that escape to it; else light sampling "
                    "alone for emitters (near-mirror GGX lobes by bounces alone), bounces alone for the "
                    "environment")


register_group("reference", ReferenceOptions)


class ReferencePass(RtPass):
    name = "reference"
    options = ReferenceOptions
    option_groups = ("reflections",)  # reflections.roughness_threshold: what reflects
    writes = ("radiance",)
    stream = 5

    @classmethod
    def parameters(cls, opts) -> dict:
        return {"threshold": opts.get("reflections.roughness_threshold"),
                "max_bounces": opts.get("reference.max_bounces"), "rr_start": opts.get("reference.rr_start"),
                "mis": opts.get("reference.mis")}
