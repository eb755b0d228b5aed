"""Each pass mode (`--pass NAME`) as a small graph declared as data: the passes it runs, in
order, each with the options under which it runs. The renderer wires the channels from the
passes' reads and writes; the viewer's panel shows the option groups of the graph's passes.
Every mode ends in accumulation and display (TAIL), with the reprojection of the accumulated
history before it (option reproject) but in the G-buffer views; the ray-traced effects' modes
with a denoiser each side of the accumulation (DENOISED_TAIL: option denoise)."""
from __future__ import annotations

from dataclasses import dataclass

from app.raster.channel_view import CHANNEL_VIEWS
from rt.effects import EFFECTS
from rt.hybrid import EFFECTS as HYBRID_EFFECTS


@dataclass(frozen=True)
class Node:
    pass_name: str  # a key of Renderer.passes
    when: tuple = ()  # (option key, value) pairs that must all hold for the pass to run


RASTER = (("gbuffer", "raster"),)
RT_PRIMARY = (("gbuffer", "rt"),)
# the front of a ray-traced mode: the raster G-buffer read back, or primary rays on the backend
RT_FRONT = (Node("gbuffer", RASTER), Node("gbuffer_pack", RASTER), Node("primary"))
FORWARD = (Node("shadow_maps"), Node("ssao"), Node("forward"))
EFFECT_MODES = EFFECTS  # each effect alone, on the G-buffer (rt/effects.py)
SVGF, OIDN, REPROJECT = (("denoise", "svgf"),), (("denoise", "oidn"),), (("reproject", True),)
# the denoisers and the reprojection read the raster G-buffer: rasterised for them where the
# rays make their own primary hits
GL_GBUFFER = tuple(Node("gbuffer", RT_PRIMARY + when) for when in (SVGF, OIDN, REPROJECT))


def _hybrid_input(effect: str) -> Node:
    when = ((f"hybrid.{effect}", True),) + ((("hybrid.gi", False),) if effect == "ao" else ())
    return Node(effect, when)


MODES: dict[str, tuple[Node, ...]] = {
    "forward": (Node("gbuffer"),) + FORWARD,
    # the forward graph with ray-traced inputs (rt/hybrid.py): always on the raster G-buffer
    "hybrid": (Node("gbuffer"), Node("gbuffer_pack"), Node("primary"))
    + tuple(_hybrid_input(e) for e in HYBRID_EFFECTS) + FORWARD,
    **{effect: GL_GBUFFER + RT_FRONT + (Node(effect),) for effect in EFFECT_MODES},
    **{view: (Node("gbuffer", RASTER), Node("channel_view", RASTER), Node("primary", RT_PRIMARY),
              Node("gbuffer_view", RT_PRIMARY)) for view in CHANNEL_VIEWS},
}
TAIL = (Node("accumulation"), Node("display"))
REPROJECTED_TAIL = (Node("reproject", REPROJECT),) + TAIL
DENOISED_TAIL = (Node("svgf", SVGF), Node("reproject", REPROJECT), Node("accumulation"), Node("oidn", OIDN),
                 Node("display"))


def denoises(mode: str) -> bool:
    """Whether option denoise applies to a mode: the ray-traced effects and the reference (not
    forward, hybrid or the G-buffer views)."""
    return mode in EFFECT_MODES


def check_denoise(mode: str, options) -> None:
    """A denoiser asked for where none runs: one line for the user (UserError)."""
    from core.errors import UserError

    if options.get("denoise") != "off" and not denoises(mode):
        raise UserError(f"denoise={options.get('denoise')} applies to the ray-traced passes "
                        f"({', '.join(EFFECT_MODES)}), not to --pass {mode}")


def tail(mode: str) -> tuple[Node, ...]:
    if mode in EFFECT_MODES:
        return DENOISED_TAIL
    return TAIL if mode in CHANNEL_VIEWS else REPROJECTED_TAIL


def gbuffer_source(options, tracer: str, software_gl: bool, mode: str) -> str:
    """Option gbuffer resolved (raster or rt) for a frame of pass `mode` traced by `tracer`
    (resolved) on an OpenGL that is (software_gl) or is not a CPU rasteriser. auto: primary rays
    for the ray-traced effects where Embree traces on a CPU rasteriser (there the rays cost less
    than rasterising: report/local-issue43, report/HISTORY.md), unless the frame rasterises the
    G-buffer anyway (a denoiser, reproject: GL_GBUFFER); the raster G-buffer for its own views
    and elsewhere. A GPU backend traces its own primary hits
    whatever this says (Backend.wants_gbuffer)."""
    asked = options.get("gbuffer")
    if asked != "auto":
        return asked
    rasterised_anyway = any(all(options.get(k) == v for k, v in n.when if k != "gbuffer") for n in GL_GBUFFER)
    cheaper = tracer == "embree" and software_gl and mode in EFFECT_MODES
    return "rt" if cheaper and not rasterised_anyway else "raster"


def finish_on_tracer(options, tracer: str, software_gl: bool) -> bool:
    """Option finish resolved for a frame traced by `tracer` (resolved) on an OpenGL that is
    (software_gl) or is not a CPU rasteriser: whether the backend accumulates and tone-maps the
    frame itself (Backend.present). auto: a GPU backend always (its images are on its device);
    Embree where GL is software (at 1280x720 on llvmpipe GL's float upload, accumulation and tone
    mapping took 15-17 ms, Embree's threads 2-3 ms and an 8-bit upload: report/HISTORY.md)."""
    asked = options.get("finish")
    if asked != "auto":
        return asked == "tracer"
    return tracer != "embree" or software_gl


class Resolved:
    """Options with some keys' values given here instead (the graph's view of option gbuffer=auto)."""

    def __init__(self, options, **values):
        self.options, self.values = options, values

    def get(self, key: str):
        return self.values[key] if key in self.values else self.options.get(key)


def active(mode: str, options) -> list[str]:
    """The passes a mode runs under these options, in order, the tail included; option gbuffer as
    resolved (Resolved: Renderer.gbuffer_source), or where it is still auto the raster one."""
    if options.get("gbuffer") not in ("raster", "rt"):
        options = Resolved(options, gbuffer="raster")
    return [n.pass_name for n in MODES[mode] + tail(mode) if all(options.get(k) == v for k, v in n.when)]


def every_pass(mode: str) -> list[str]:
    """Every pass a mode may run, whatever the options (the panel shows all their options): the
    tail's with options of their own (the denoisers) too."""
    return list(dict.fromkeys(n.pass_name for n in MODES[mode] + tail(mode)
                              if n.pass_name not in ("accumulation", "display", "reproject")))


MODE_OPTIONS = {"hybrid": ("hybrid",)}  # a mode's own option groups, besides its passes'


def option_groups(mode: str) -> list[str]:
    """The option groups the panel shows for a mode: the mode's own, then its passes'."""
    from app.passes import PASS_CLASSES
    from app.passes import option_groups as groups_of

    return list(dict.fromkeys(list(MODE_OPTIONS.get(mode, ())) + groups_of(PASS_CLASSES[p] for p in every_pass(mode))))
