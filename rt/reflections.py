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


def shade_local(cf, s, rng, lit: bool) -> np.ndarray:
    """Colour of a surface without its reflection: diffuse direct light, or the material colour."""
    if lit:
        return s.albedo * INV_PI * direct_one(cf.data, cf.tracer, s, rng)
    return s.albedo.copy()


def reflected_radiance(cf, s, incoming, rng, depth: int) -> np.ndarray:
    """Radiance arriving along the mirror direction at surfaces s, following up to `depth` mirrors.
    Every step runs even on no points, so each pixel draws the same numbers however it is chunked."""
    thr = cf.options.get("reflections.roughness_threshold")
    lit = cf.options.get("reflections.lit")
    d = mirror(incoming, s)
    out = np.zeros((len(s), 3), np.float32)
    hit, sh, miss = trace_from(cf.data, cf.tracer, s, d)
    if miss.size:
        out[miss] = cf.environment.radiance(d[miss])
    hrng = rng.subset(hit)
    color = sh.emissive + shade_local(cf, sh, hrng, lit)
    if depth > 1:
        smooth = np.nonzero(sh.roughness < thr)[0]
        ss = sh.take(smooth)
        f = fresnel_schlick(ss, d[hit][smooth])
        inner = reflected_radiance(cf, ss, d[hit][smooth], hrng.subset(smooth), depth - 1)
        color[smooth] = ss.emissive + (1 - f) * (color[smooth] - ss.emissive) + f * inner
    out[hit] = color
    return out


def reflect(cf) -> tuple[np.ndarray, np.ndarray]:
    """A chunk's colour with reflections blended in (without emission), and the reflection
    itself as RGBA (alpha 1 where a reflection ray was traced)."""
    s = cf.s
    rng = cf.rng(3)
    local = shade_local(cf, s, rng, cf.options.get("reflections.lit"))
    smooth = np.nonzero(s.roughness < cf.options.get("reflections.roughness_threshold"))[0]
    reflection = np.zeros((len(s), 4), np.float32)
    ss = s.take(smooth)
    view = cf.view[smooth]
    refl = reflected_radiance(cf, ss, view, rng.subset(smooth), cf.options.get("reflections.max_depth"))
    f = fresnel_schlick(ss, view)
    local[smooth] = (1 - f) * local[smooth] + f * refl  # emission is added unblended by the caller
    reflection[smooth, :3] = refl
    reflection[smooth, 3] = 1.0
    return local, reflection


class ReflectionsPass:
    name = "reflections"
    reads = ("gbuffer",)
    writes = ("radiance", "rt_reflection")

    def reset(self) -> None:
        pass

    def execute(self, rf) -> dict:
        out, reflection_image = rf.background(), rf.image(4)

        def work(cf):
            local, reflection = reflect(cf)
            cf.put(out, cf.s.emissive + local)
            cf.put(reflection_image, reflection)

        rf.for_chunks(work)
        return {"radiance": out, "rt_reflection": reflection_image}
