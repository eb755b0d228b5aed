"""Hybrid: the forward baseline with chosen effects swapped for their ray-traced versions
(RT shadows for shadow maps, RT AO for SSAO, RT reflections for environment reflections,
RT GI as the indirect light instead of the ambient term). Each RT effect uses its own pass's
options; the forward lighting shader combines them (shaders/forward.frag)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from app.options import opt, register_group
from rt.ao import ambient_occlusion
from rt.gi import indirect_light
from rt.reflections import reflect
from rt.shadows import direct_irradiance


@dataclass
class HybridOptions:
    shadows: bool = opt(True, "ray-traced shadows instead of shadow maps")
    ao: bool = opt(True, "ray-traced AO instead of SSAO")
    reflections: bool = opt(False, "ray-traced reflections instead of environment reflections")
    gi: bool = opt(False, "ray-traced indirect light instead of the ambient term")


register_group("hybrid", HybridOptions)
EFFECTS = ("shadows", "ao", "reflections", "gi")


def hybrid_components(rf) -> dict:
    """The ray-traced pieces the forward shader swaps in, as full-image arrays."""
    opts = rf.options
    shadows, reflections, gi = opts.get("hybrid.shadows"), opts.get("hybrid.reflections"), opts.get("hybrid.gi")
    ao = opts.get("hybrid.ao") and not gi
    out = {}
    if shadows:
        out["rt_direct"] = rf.image(name="direct")
    if ao:
        out["rt_ao"] = rf.image(1, fill=1.0)
    if reflections:
        out["rt_reflection"] = rf.image(4)
    if gi:
        out["rt_indirect"] = rf.image(name="indirect")

    def work(cf):
        if shadows:
            cf.put(out["rt_direct"], direct_irradiance(cf))
        if ao:
            cf.put(out["rt_ao"], ambient_occlusion(cf) / np.float32(opts.get("ao.rays_per_pixel")))
        if reflections:
            reflection = np.zeros((len(cf.s), 4), np.float32)
            reflect(cf, reflection)
            cf.put(out["rt_reflection"], reflection)
        if gi:
            cf.put(out["rt_indirect"], indirect_light(cf, cf.s, cf.rng(6)))

    if out:  # the random streams of direct_irradiance, ambient_occlusion, reflect and this GI
        rf.for_chunks(work, streams=tuple(s for s, on in ((1, shadows), (2, ao), (3, reflections), (6, gi)) if on))
    return out


def enabled_effects(options) -> list[str]:
    return [e for e in EFFECTS if options.get(f"hybrid.{e}")]
