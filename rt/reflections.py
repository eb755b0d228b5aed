"""Ray-traced reflections: where the G-buffer's roughness is below the threshold, trace the
mirror direction and shade the hit; Schlick's Fresnel blends the reflection with the local
colour. `lit=false` reproduces the study (hits show their material colour only).
Backends: rt/embree/reflections.py."""
from __future__ import annotations

from dataclasses import dataclass

from core.options import opt, register_group
from rt.pass_base import SPECULAR, RtPass


@dataclass
class ReflectionsOptions:
    roughness_threshold: float = opt(0.3, "reflect on surfaces smoother than this", 0.0, 1.0)
    max_depth: int = opt(1, "mirror bounces (the study used 1)", 1, 16)
    lit: bool = opt(True, "shade hits with direct light and shadow rays (false: material colour, as the study)")
    glossy: bool = opt(False, "with brdf=ggx and lit hits: surfaces at or above the threshold reflect one ray from "
                       "their GGX lobe per pixel and frame (accumulation converges it); false: the study's")


register_group("reflections", ReflectionsOptions)


class ReflectionsPass(RtPass):
    name = "reflections"
    options = ReflectionsOptions
    writes = ("radiance", "rt_reflection", SPECULAR)
    stream = 3
    aux_channels = 4

    @classmethod
    def parameters(cls, opts) -> dict:
        return {"threshold": opts.get("reflections.roughness_threshold"), "depth": opts.get("reflections.max_depth"),
                "lit": opts.get("reflections.lit"), "glossy": opts.get("reflections.glossy")}

    @classmethod
    def splits_specular(cls, opts, scene) -> bool:
        """Lit colours only: unlit ones (the study's) are the albedo blended by Fresnel."""
        return super().splits_specular(opts, scene) and bool(opts.get("reflections.lit"))
