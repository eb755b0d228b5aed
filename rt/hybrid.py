"""Hybrid: the forward baseline with chosen effects swapped for their ray-traced versions
(RT shadows for shadow maps, RT AO for SSAO, RT reflections for environment reflections,
RT GI as the indirect light instead of the ambient term). Each RT effect runs as its own pass
with its own options, writing the image the forward shader reads (shaders/forward.frag);
the graph is declared in app/graph.py."""
from __future__ import annotations

from dataclasses import dataclass

from core.options import opt, register_group


@dataclass
class HybridOptions:
    shadows: bool = opt(True, "ray-traced shadows instead of shadow maps")
    ao: bool = opt(True, "ray-traced AO instead of SSAO")
    reflections: bool = opt(False, "ray-traced reflections instead of environment reflections")
    gi: bool = opt(False, "ray-traced indirect light instead of the ambient term")


register_group("hybrid", HybridOptions)
EFFECTS = ("shadows", "ao", "reflections", "gi")
