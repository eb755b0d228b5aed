"""SVGF denoiser (`denoise=svgf`): spatio-temporal variance-guided filtering (Schied et al. 2017)
of a ray-traced pass's radiance, as GL passes on the raster G-buffer, so it serves every backend
(those that filter on their own GPU run rt/svgf.py's pass instead: the same filter as compute
kernels, shaders/rt/svgf.slang; option svgf.device): the first hit's emission left out (added
back at the end: light sources stay sharp), temporal accumulation of the lighting demodulated by
albedo through the motion vectors, with disocclusion tests (shaders/svgf_temporal.frag), an even
average of a still view's first 1/alpha frames; the variance of that average (the temporal
moments' over the frames it holds or, for a short history, the neighbours', svgf_variance.frag),
then `iterations` a-trous passes with edge-stopping on depth, normal and luminance, the latter
the reprojected history's (which this frame's noise has no part in: with the frame's own, the
filter leaned towards each pixel's noise, 1-ray AO 3.8 % dark) (svgf_atrous.frag), so that the
filter narrows as the average converges; the last multiplies the albedo back. The next frame
reprojects the temporal average (with `feedback`, the first iteration's output, as the paper).
With `resolve`, the filtered frames are averaged over time in turn (svgf_resolve.frag), so that
edges, which one jittered G-buffer sample a pixel aliases, blend as in accumulation."""
from __future__ import annotations

from app.gl_context import bind_channels, fullscreen, set_uniform
from app.raster.targets import Targets
from core.passes import Pass
from rt.pass_base import SPECULAR
from rt.svgf import SvgfHistory, SvgfOptions

GBUFFER = ("g_position", "g_normal", "g_albedo", "g_emissive", "g_face")


class _Run:
    """The targets of one run of the filter (the whole lighting, or one of its parts): its
    temporal average, the history the next frame reprojects, the variance, the a-trous images."""

    def __init__(self, ctx):
        self.temporal = Targets(ctx, {"color": (4, "f4"), "moments": (4, "f4")})
        self.history = Targets(ctx, {"color": (4, "f4"), "moments": (4, "f4"), "position": (4, "f4"),
                                     "normal": (4, "f4")})
        self.variance = Targets(ctx, {"c": (4, "f4")})
        self.ping = Targets(ctx, {"c": (4, "f4")})
        self.pong = Targets(ctx, {"c": (4, "f4")})
        self.out = Targets(ctx, {"c": (4, "f4")})

    def all(self) -> tuple:
        return self.temporal, self.history, self.variance, self.ping, self.pong, self.out


class SvgfPass(Pass):
    """The radiance of the frame, filtered; history kept from frame to frame (not reset by
    camera motion: that is what the reprojection is for). With glTF's BRDF the radiance's
    specular part (SPECULAR) is filtered in a run of its own, after the diffuse part's."""

    name = "svgf"
    options = SvgfOptions
    reads = ("radiance", "g_position", "g_normal", "g_albedo", "g_emissive", "g_face", "g_motion", SPECULAR)
    writes = ("radiance",)

    def __init__(self, ctx):
        self.ctx = ctx
        self.runs = [_Run(ctx), _Run(ctx)]  # the diffuse part (or the whole lighting), the specular
        self.resolved = [Targets(ctx, {"c": (4, "f4")}), Targets(ctx, {"c": (4, "f4")})]  # this frame's, the last
        self.kept = SvgfHistory()  # whether the history may be reprojected

    def set_scene(self, scene) -> None:
        self.kept.reset()

    def reset(self) -> None:
        self.kept.reset()

    def execute(self, frame) -> None:
        w, h = frame.width, frame.height
        run = self.kept.begin(frame)
        split = run.split and SPECULAR in frame.channels
        for t in (*self.runs[0].all(), *(self.runs[1].all() if split else ()), *self.resolved):
            t.ensure(w, h)
        with frame.profiler.gpu(self.ctx, "svgf"):
            result = self._filter(frame, run, self.runs[0], split, 0, None)
            if split:
                result = self._filter(frame, run, self.runs[1], split, 1, result)
            if run.opts.resolve:
                target, last = self.resolved
                prog, vao = fullscreen(self.ctx, "svgf_resolve.frag")
                self._draw(target, prog, vao, frame, ("g_motion",), {"current": result, "previous": last["c"]},
                           has_history=int(run.resolved), alpha=float(run.opts.resolve_alpha))
                self.resolved.reverse()
                result = target["c"]
        self.kept.end(run)
        frame.channels["radiance"] = result

    def _filter(self, frame, run, targets: _Run, split: bool, signal: int, diffuse):
        """One run over the lighting (signal 0: the diffuse part, or the whole where not split;
        1: the specular part, whose last iteration adds the diffuse run's result): its image."""
        opts = run.opts
        terms = {"has_albedo": int(run.has_albedo), "has_emission": int(run.has_emission), "split": int(split),
                 "signal": signal, "eye": tuple(map(float, frame.camera.eye))}
        spec = (SPECULAR,) if split else ()
        prog, vao = fullscreen(self.ctx, "svgf_temporal.frag")
        self._draw(targets.temporal, prog, vao, frame, ("radiance",) + GBUFFER + ("g_motion",) + spec, {
            "prev_color": targets.history["color"], "prev_moments": targets.history["moments"],
            "prev_position": targets.history["position"], "prev_normal": targets.history["normal"]},
            has_history=int(run.history), alpha=float(opts.alpha), moments_alpha=float(opts.moments_alpha), **terms)
        prog, vao = fullscreen(self.ctx, "svgf_variance.frag")
        self._draw(targets.variance, prog, vao, frame, ("g_position", "g_normal", "g_face"), {
            "color": targets.temporal["color"], "moments": targets.temporal["moments"]},
            phi_normal=float(opts.phi_normal), alpha=float(opts.alpha), of_average=int(not opts.feedback))
        source = targets.variance["c"]
        prog, vao = fullscreen(self.ctx, "svgf_atrous.frag")
        n = run.iterations
        extra = {"diffuse": diffuse} if diffuse is not None else {}
        for i in range(n):
            last = i == n - 1
            target = targets.out if last else (targets.ping if i % 2 == 0 else targets.pong)
            self._draw(target, prog, vao, frame, GBUFFER + ("radiance",), {"color": source,
                                                                         "guide": targets.temporal["moments"],
                                                                         **extra},
                       step=1 << i, phi_color=float(opts.phi_color), phi_normal=float(opts.phi_normal),
                       phi_depth=float(opts.phi_depth), remodulate=int(last), **terms)
            source = target["c"]
            if i == 0:  # what the next frame reprojects: the temporal average (or the first iteration's)
                keep, kvao = fullscreen(self.ctx, "svgf_history.frag")
                if opts.feedback:
                    first = targets.variance["c"] if last else source  # one iteration: its input
                else:
                    first = targets.temporal["color"]
                self._draw(targets.history, keep, kvao, frame, ("g_position", "g_normal", "g_face"), {
                    "filtered": first, "color": targets.temporal["color"], "moments": targets.temporal["moments"]})
        return targets.out["c"]

    def _draw(self, target, prog, vao, frame, channels, textures: dict, **uniforms) -> None:
        target.fbo.use()
        target.fbo.viewport = (0, 0, frame.width, frame.height)
        bind_channels(prog, frame, channels)
        for unit, (name, tex) in enumerate(textures.items(), start=len(channels)):
            tex.use(unit)
            set_uniform(prog, name, unit)
        for name, value in uniforms.items():
            set_uniform(prog, name, value)
        vao.render(vertices=3)

    def release(self) -> None:
        for t in (*self.runs[0].all(), *self.runs[1].all(), *self.resolved):
            t.release()
