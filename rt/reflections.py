"""Ray-traced reflections: where the G-buffer's roughness is below the threshold, trace the
mirror direction and shade the hit; Schlick's Fresnel blends the reflection with the local
colour. `lit=false` reproduces the study (hits show their material colour only)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from app.options import opt, register_group
from rt.shading import INV_PI, direct_one, fresnel_schlick, mirror, trace_from


@dataclass
class ReflectionsOptions:
    roughness_threshold: float = opt(0.3, "reflect on surfaces smoother than this", 0.0, 1.0)
    max_depth: int = opt(1, "mirror bounces (the study used 1)", 1, 16)
    lit: bool = opt(True, "shade hits with direct light and shadow rays (false: material colour, as the study)")


register_group("reflections", ReflectionsOptions)


def shade_local(rf, s, rng, lit: bool) -> np.ndarray:
    """Colour of a surface without its reflection: diffuse direct light, or the material colour."""
    if lit:
        return s.albedo * INV_PI * direct_one(rf.data, rf.tracer, s, rng)
    return s.albedo.copy()


def reflected_radiance(rf, s, incoming, rng, depth: int) -> np.ndarray:
    """Radiance arriving along the mirror direction at surfaces s, following up to `depth` mirrors."""
    thr = rf.options.get("reflections.roughness_threshold")
    lit = rf.options.get("reflections.lit")
    d = mirror(incoming, s)
    out = np.zeros((len(s), 3), np.float32)
    hit, sh, miss = trace_from(rf.data, rf.tracer, s, d)
    if miss.size:
        out[miss] = rf.environment.radiance(d[miss])
    if hit.size:
        hrng = rng.subset(hit)
        color = sh.emissive + shade_local(rf, sh, hrng, lit)
        if depth > 1:
            smooth = np.nonzero(sh.roughness < thr)[0]
            if smooth.size:
                ss = sh.take(smooth)
                f = fresnel_schlick(ss, d[hit][smooth])
                inner = reflected_radiance(rf, ss, d[hit][smooth], hrng.subset(smooth), depth - 1)
                color[smooth] = ss.emissive + (1 - f) * (color[smooth] - ss.emissive) + f * inner
        out[hit] = color
    return out


class ReflectionsPass:
    name = "reflections"
    reads = ("gbuffer",)
    writes = ("radiance", "rt_reflection")

    def reset(self) -> None:
        pass

    def execute(self, rf) -> dict:
        s = rf.gb.surface
        rng = rf.rng(3)
        lit = rf.options.get("reflections.lit")
        local = shade_local(rf, s, rng, lit)
        view = rf.gb.view_dir[rf.gb.index]
        smooth = np.nonzero(s.roughness < rf.options.get("reflections.roughness_threshold"))[0]
        reflection = np.zeros((len(s), 4), np.float32)
        if smooth.size:
            ss = s.take(smooth)
            refl = reflected_radiance(rf, ss, view[smooth], rng.subset(smooth), rf.options.get("reflections.max_depth"))
            f = fresnel_schlick(ss, view[smooth])
            local[smooth] = (1 - f) * local[smooth] + f * refl  # emission is added unblended below
            reflection[smooth, :3] = refl
            reflection[smooth, 3] = 1.0
        out = rf.background()
        out[rf.gb.index] = s.emissive + local
        return {"radiance": out, "rt_reflection": rf.full(reflection)}
