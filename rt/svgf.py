"""SVGF's options (`denoise=svgf`) and its pass on a ray-tracing device: where the frame's
backend filters on its own GPU (Backend.denoisers, the Slang backends: rt/slang/svgf.py), the
renderer runs this pass in place of the GL one (app/raster/svgf.py), on the device's G-buffer
and radiance, so that the denoised frame is accumulated and shown without leaving the device.
The same filter either way: shaders/rt/svgf.slang is the GL passes' code as compute kernels."""
from __future__ import annotations

from dataclasses import dataclass

from core.options import opt, register_group
from core.passes import Pass
from rt.effects import PASSES, radiance_terms
from rt.pass_base import SPECULAR


@dataclass
class SvgfOptions:
    iterations: int = opt(0, "a-trous iterations (5 x 5 taps, 2^i apart: 3 reach 14 pixels; the paper used 5, which "
                          "blurred the built-in scenes' lighting more than it removed noise); 0: the effect's own "
                          "(AO 1, the others 3)", 0, 8)
    alpha: float = opt(1 / 32, "weight of the new frame in the temporal accumulation (at least: a still view "
                       "averages its first 1/alpha frames evenly; the paper's 0.2 keeps about 9)", 0.01, 1.0)
    moments_alpha: float = opt(0.2, "weight of the new frame in the luminance moments (at least)", 0.01, 1.0)
    feedback: bool = opt(False, "reproject the first a-trous iteration's output, as the paper does (blurs the "
                         "history frame after frame), instead of the temporal average")
    phi_color: float = opt(8.0, "luminance edge-stopping, in standard deviations of the averaged lighting", 0.1,
                           1000.0)
    phi_normal: float = opt(128.0, "normal edge-stopping exponent", 1.0, 1024.0)
    phi_depth: float = opt(1.0, "depth edge-stopping, in 1 % of the depth per a-trous step", 0.01, 100.0)
    resolve: bool = opt(True, "average the filtered frames over time (reprojected, clamped where the camera moved), "
                        "as raw accumulation averages jittered frames: edges stop aliasing")
    resolve_alpha: float = opt(0.1, "weight of the new frame in that average (at least)", 0.01, 1.0)
    split: bool = opt(True, "with glTF's BRDF: filter the specular part of the lighting apart from the diffuse, "
                      "each over its own albedo (highlights are not divided by the texture nor blurred with the "
                      "diffuse light)")
    device: bool = opt(True, "filter on the ray-tracing backend's GPU where it has one (vulkan, cuda: the frame "
                       "stays on the device); false, or on embree: as GL passes on the raster G-buffer")


register_group("svgf", SvgfOptions)


@dataclass(frozen=True)
class SvgfFrame:
    """What one frame's filter runs with, on GL or on a device (Backend.svgf)."""

    opts: SvgfOptions  # the frame's svgf group
    iterations: int  # a-trous iterations: the option's, or the effect's own (RtPass.svgf_iterations)
    has_albedo: bool  # the radiance holds the first hit's albedo as a factor (RtPass.radiance_terms)
    has_emission: bool  # and its emission
    split: bool = False  # its specular part comes apart (RtPass.splits_specular): filtered in a run of its own
    history: bool = False  # the last frame's temporal history may be reprojected
    resolved: bool = False  # and its resolved image


def svgf_frame(frame, history: bool, resolved: bool) -> SvgfFrame:
    opts = frame.options.group("svgf")
    effect = PASSES.get(frame.mode)
    iterations = int(opts.iterations) or (effect.svgf_iterations if effect is not None else 3)
    split = effect is not None and effect.splits_specular(frame.options, frame.scene)
    return SvgfFrame(opts, iterations, *radiance_terms(frame.mode, frame.options), split, history, resolved)


class SvgfHistory:
    """Whether an SVGF pass's history (GL's or the device's) may be reprojected into this frame:
    dropped for another image (size), mode, option or scene, and whatever else the pass names."""

    def __init__(self):
        self.valid = self.resolved_valid = False
        self.inputs = None  # what the history was made under

    def reset(self) -> None:
        self.valid = self.resolved_valid = False

    def begin(self, frame, *also) -> SvgfFrame:
        """This frame's run, with the history it may use."""
        inputs = (frame.mode, frame.options.state(), id(frame.scene), frame.width, frame.height, *also)
        if inputs != self.inputs:
            self.valid, self.resolved_valid, self.inputs = False, False, inputs
        return svgf_frame(frame, self.valid, self.resolved_valid)

    def end(self, run: SvgfFrame) -> None:
        """The frame's history made: the next frame may reproject it (and its resolved image)."""
        self.valid, self.resolved_valid = True, bool(run.opts.resolve)


class DeviceSvgfPass(Pass):
    """SVGF on the backend's device; the history is kept there from frame to frame, dropped as
    the GL pass drops its own (SvgfHistory), and for another backend."""

    name = "svgf_device"
    device = "rt"
    reads = ("radiance", "gbuffer", SPECULAR)
    writes = ("radiance",)

    def __init__(self):
        self.history = SvgfHistory()

    def set_scene(self, scene) -> None:
        self.history.reset()

    def reset(self) -> None:
        self.history.reset()

    def execute(self, frame) -> None:
        with frame.profiler.cpu("svgf"):
            run = self.history.begin(frame, id(frame.backend))
            frame.channels["radiance"] = frame.backend.svgf(frame.channels["radiance"], run,
                                                            frame.channels.get(SPECULAR))
        self.history.end(run)
