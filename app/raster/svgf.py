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
from rt.svgf import SvgfHistory, SvgfOptions

GBUFFER = ("g_position", "g_normal", "g_albedo", "g_emissive", "g_face")


class SvgfPass(Pass):
    """The radiance of the frame, filtered; history kept from frame to frame (not reset by
    camera motion: that is what the reprojection is for)."""

    name = "svgf"
    options = SvgfOptions
    reads = ("radiance", "g_position", "g_normal", "g_albedo", "g_emissive", "g_face", "g_motion")
    writes = ("radiance",)

    def __init__(self, ctx):
        self.ctx = ctx
        self.temporal = Targets(ctx, {"color": (4, "f4"), "moments": (4, "f4")})
        self.history = Targets(ctx, {"color": (4, "f4"), "moments": (4, "f4"), "position": (4, "f4"),
                                     "normal": (4, "f4")})
        self.variance = Targets(ctx, {"c": (4, "f4")})
        self.ping = Targets(ctx, {"c": (4, "f4")})
        self.pong = Targets(ctx, {"c": (4, "f4")})
        self.out = Targets(ctx, {"c": (4, "f4")})
        self.resolved = [Targets(ctx, {"c": (4, "f4")}), Targets(ctx, {"c": (4, "f4")})]  # this frame's, the last
        self.kept = SvgfHistory()  # whether the history may be reprojected

    def set_scene(self, scene) -> None:
        self.kept.reset()

    def reset(self) -> None:
        self.kept.reset()

    def execute(self, frame) -> None:
        w, h = frame.width, frame.height
        run = self.kept.begin(frame)
        opts = run.opts
        for t in (self.temporal, self.history, self.variance, self.ping, self.pong, self.out, *self.resolved):
            t.ensure(w, h)
        terms = {"has_albedo": int(run.has_albedo), "has_emission": int(run.has_emission)}
        with frame.profiler.gpu(self.ctx, "svgf"):
            prog, vao = fullscreen(self.ctx, "svgf_temporal.frag")
            self._draw(self.temporal, prog, vao, frame, ("radiance",) + GBUFFER + ("g_motion",), {
                "prev_color": self.history["color"], "prev_moments": self.history["moments"],
                "prev_position": self.history["position"], "prev_normal": self.history["normal"]},
                has_history=int(run.history), alpha=float(opts.alpha), moments_alpha=float(opts.moments_alpha), **terms)
            prog, vao = fullscreen(self.ctx, "svgf_variance.frag")
            self._draw(self.variance, prog, vao, frame, ("g_position", "g_normal", "g_face"), {
                "color": self.temporal["color"], "moments": self.temporal["moments"]},
                phi_normal=float(opts.phi_normal), alpha=float(opts.alpha), of_average=int(not opts.feedback))
            source = self.variance["c"]
            prog, vao = fullscreen(self.ctx, "svgf_atrous.frag")
            n = run.iterations
            for i in range(n):
                last = i == n - 1
                target = self.out if last else (self.ping if i % 2 == 0 else self.pong)
                self._draw(target, prog, vao, frame, GBUFFER + ("radiance",), {"color": source,
                                                                             "guide": self.temporal["moments"]},
                           step=1 << i, phi_color=float(opts.phi_color), phi_normal=float(opts.phi_normal),
                           phi_depth=float(opts.phi_depth), remodulate=int(last), **terms)
                source = target["c"]
                if i == 0:  # what the next frame reprojects: the temporal average (or the first iteration's)
                    keep, kvao = fullscreen(self.ctx, "svgf_history.frag")
                    if opts.feedback:
                        first = self.variance["c"] if last else source  # one iteration: its input
                    else:
                        first = self.temporal["color"]
                    self._draw(self.history, keep, kvao, frame, ("g_position", "g_normal", "g_face"), {
                        "filtered": first, "color": self.temporal["color"], "moments": self.temporal["moments"]})
            result = self.out
            if opts.resolve:
                result, last = self.resolved
                prog, vao = fullscreen(self.ctx, "svgf_resolve.frag")
                self._draw(result, prog, vao, frame, ("g_motion",), {"current": self.out["c"],
                                                                     "previous": last["c"]},
                           has_history=int(run.resolved), alpha=float(opts.resolve_alpha))
                self.resolved.reverse()
        self.kept.end(run)
        frame.channels["radiance"] = result["c"]

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
        for t in (self.temporal, self.history, self.variance, self.ping, self.pong, self.out, *self.resolved):
            t.release()
