"""Pass names of the CLI contract, and every pass's class: importing this module registers
every pass's option group (core.options)."""
from app.raster.channel_view import CHANNEL_VIEWS, ChannelViewPass
from app.raster.forward_lighting import ForwardLightingPass
from app.raster.gbuffer import GBufferPass
from app.raster.gbuffer_pack import GBufferPackPass
from app.raster.oidn import OidnPass
from app.raster.postprocess import AccumulationPass, DisplayPass
from app.raster.reproject import ReprojectPass
from app.raster.shadow_maps import ShadowMapPass
from app.raster.ssao import SSAOPass
from app.raster.svgf import SvgfPass
from core.errors import UserError
from rt import hybrid  # noqa: F401  (registers the hybrid group)
from rt.effects import EFFECTS, PASSES
from rt.pass_base import GBufferViewPass, PrimaryPass
from rt.svgf import DeviceSvgfPass

RASTER = ("forward",)
# the effects (rt/effects.py), then hybrid, the reference (the ground truth) last
RAY_TRACED = tuple(e for e in EFFECTS if e != "reference") + ("hybrid", "reference")
ALL = RASTER + RAY_TRACED + CHANNEL_VIEWS

GL_PASSES = (GBufferPass, GBufferPackPass, ShadowMapPass, SSAOPass, ForwardLightingPass, ChannelViewPass,
             SvgfPass, ReprojectPass, AccumulationPass, OidnPass, DisplayPass)  # made with the GL context
RT_PASSES = (PrimaryPass, *PASSES.values(), GBufferViewPass, DeviceSvgfPass)


def create_passes(ctx) -> dict:
    """One instance of every pass, by name (the graph's nodes name them: app/graph.py)."""
    passes = [cls(ctx) for cls in GL_PASSES] + [cls() for cls in RT_PASSES]
    return {p.name: p for p in passes}


def option_groups(pass_classes) -> list[str]:
    """The option groups of these passes (their own, then the ones they also read)."""
    groups = []
    for cls in pass_classes:
        groups += ([cls.name] if cls.options is not None else []) + list(cls.option_groups)
    return list(dict.fromkeys(groups))


PASS_CLASSES = {cls.name: cls for cls in GL_PASSES + RT_PASSES}


def check_pass(name: str) -> str:
    if name not in ALL:
        raise UserError(f"unknown pass {name!r}; choose one of {', '.join(ALL)}")
    return name
