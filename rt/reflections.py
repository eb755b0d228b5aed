"""Ray-traced reflections: where the G-buffer's roughness is below the threshold, trace the
mirror direction and shade the hit; Schlick's Fresnel blends the reflection with the local
colour. `lit=false` reproduces the study (hits show their material colour only)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from app.options import opt, register_group
from rt import gather, scratch
from rt.shading import INV_PI, direct_one, empty_surface


@dataclass
class ReflectionsOptions:
    roughness_threshold: float = opt(0.3, "reflect on surfaces smoother than this", 0.0, 1.0)
    max_depth: int = opt(1, "mirror bounces (the study used 1)", 1, 16)
    lit: bool = opt(True, "shade hits with direct light and shadow rays (false: material colour, as the study)")


register_group("reflections", ReflectionsOptions)


def reflected_radiance(cf, s, sel, view, rng, depth: int, level: int = 0) -> np.ndarray:
    """Radiance arriving along the mirror directions at the points sel of s (viewed along
    `view`, one row per point of sel), following up to `depth` mirrors; a scratch buffer of
    this level. Every step runs even on no points, so each pixel draws the same numbers
    however the frame is chunked."""
    thr = cf.options.get("reflections.roughness_threshold")
    lit = cf.options.get("reflections.lit")
    m, name = sel.shape[0], f"refl{level}"
    out = scratch.buffer(name + ".out", (m, 3))
    out.fill(0)
    o, d, _, owner = scratch.rays(name, m)
    gather.mirror_rays(s.p, s.n, s.ng, view, sel, cf.data.eps, o, d)
    hits = cf.tracer.intersect(o[:m], d[:m])
    owner[:m] = np.arange(m)
    hit = scratch.buffer(name + ".hit", (m,), np.int64)
    k = gather.split_hits(hits.prim, m, d, owner, out, *gather.env_args(cf.environment), hit)
    hit = hit[:k]
    sh = cf.data.surface(hits, d, o, sel=hit, out=empty_surface(k, name + ".surface"))
    keys = scratch.buffer(name + ".keys", (k,), np.uint64)
    gather.gather_keys(rng.key, owner, hit, k, keys)  # rng: one generator per point of sel
    hrng = rng.with_keys(keys)
    direct = scratch.buffer(name + ".direct", (k, 3))
    if lit:
        direct_one(cf.data, cf.tracer, sh, hrng, out=direct)
    colour = scratch.buffer(name + ".colour", (k, 3))
    colour.fill(0)
    gather.add_hit_colour(colour, np.arange(k), k, sh.emissive, sh.albedo, direct, lit)
    if depth > 1:
        smooth = np.flatnonzero(sh.roughness < thr)
        inner = reflected_radiance(cf, sh, smooth, d[hit][smooth], hrng.subset(smooth), depth - 1, level + 1)
        gather.blend_mirror(colour, smooth, sh.emissive, sh.albedo, sh.metallic, sh.n, d[hit][smooth], inner, None)
    out[hit] = colour
    return out


def reflect(cf, reflection: np.ndarray | None = None) -> np.ndarray:
    """A chunk's colour with reflections blended in (without emission); the reflection itself
    goes into `reflection` as RGBA (alpha 1 where a reflection ray was traced), one row a point."""
    s = cf.s
    rng = cf.rng(3)
    local = scratch.buffer("refl.local", (len(s), 3))
    if cf.options.get("reflections.lit"):
        direct_one(cf.data, cf.tracer, s, rng, out=local)
        local *= s.albedo * INV_PI
    else:
        local[:] = s.albedo
    smooth = np.flatnonzero(s.roughness < cf.options.get("reflections.roughness_threshold"))
    view = cf.view[smooth]
    refl = reflected_radiance(cf, s, smooth, view, rng.subset(smooth), cf.options.get("reflections.max_depth"))
    zero = scratch.buffer("refl.zero", (len(s), 3))
    zero.fill(0)
    gather.blend_mirror(local, smooth, zero, s.albedo, s.metallic, s.n, view, refl, reflection)
    return local


class ReflectionsPass:
    name = "reflections"
    reads = ("gbuffer",)
    writes = ("radiance", "rt_reflection")

    def reset(self) -> None:
        pass

    def execute(self, rf) -> dict:
        out, reflection_image = rf.background(), rf.image(4)

        def work(cf):
            reflection = scratch.buffer("refl.rgba", (len(cf.s), 4))
            reflection.fill(0)
            local = reflect(cf, reflection)
            local += cf.s.emissive
            cf.put(out, local)
            cf.put(reflection_image, reflection)

        rf.for_chunks(work, streams=(3,))
        return {"radiance": out, "rt_reflection": reflection_image}
