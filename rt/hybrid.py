"""Hybrid: the forward baseline with chosen effects swapped for their ray-traced versions
(RT shadows for shadow maps, RT AO for SSAO, RT reflections for environment reflections,
RT GI as the indirect light instead of the ambient term). Each RT effect uses its own pass's
options; the forward lighting shader combines them (shaders/forward.frag)."""
from __future__ import annotations

from dataclasses import dataclass

from app.options import opt, register_group
from rt.ao import ambient_occlusion
from rt.gi import indirect_light
from rt.reflections import ReflectionsPass
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
    out = {}
    if opts.get("hybrid.shadows"):
        out["rt_direct"] = rf.full(direct_irradiance(rf))
    if opts.get("hybrid.ao") and not opts.get("hybrid.gi"):
        out["rt_ao"] = rf.full(ambient_occlusion(rf), fill=1.0)
    if opts.get("hybrid.reflections"):
        out["rt_reflection"] = ReflectionsPass().execute(rf)["rt_reflection"]
    if opts.get("hybrid.gi"):
        out["rt_indirect"] = rf.full(indirect_light(rf, rf.gb.surface, rf.rng(6)))
    return out


def enabled_effects(options) -> list[str]:
    return [e for e in EFFECTS if options.get(f"hybrid.{e}")]
