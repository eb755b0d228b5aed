"""Accumulation (running mean on the GPU) and display: tone mapping + FXAA to 8-bit."""
from __future__ import annotations

from app.gl_context import fullscreen, set_uniform
from app.raster.channel_view import CHANNEL_VIEWS, display_mapping
from app.raster.targets import Targets
from core.passes import Pass


class AccumulationPass(Pass):
    """Running mean of the pass output while nothing changes; reset() restarts it. With a
    reprojection (reproject=true: app/raster/reproject.py) each pixel keeps its own count and
    carries its mean through camera motion."""

    name = "accumulation"
    reads = ("radiance", "reprojection")
    writes = ("accumulated",)

    def __init__(self, ctx):
        self.ctx = ctx
        self.ping = Targets(ctx, {"c": (4, "f4")})
        self.pong = Targets(ctx, {"c": (4, "f4")})
        self.count = 0

    def reset(self) -> None:
        self.count = 0

    def execute(self, frame) -> None:
        source = frame.channels["radiance"]
        enabled, max_frames = bool(frame.options.get("accumulate")), int(frame.options.get("max_frames"))
        if not enabled:
            self.count = 0
            frame.channels["accumulated"] = source
            return
        if max_frames and self.count >= max_frames:
            frame.channels["accumulated"] = self.ping["c"]
            return
        self.ping.ensure(frame.width, frame.height)
        dst = self.pong.ensure(frame.width, frame.height)
        reprojection = frame.channels.get("reprojection")
        prog, vao = fullscreen(self.ctx, "accumulate.frag" if reprojection is None else "accumulate_reproject.frag")
        with frame.profiler.gpu(self.ctx, "accumulation"):
            dst.fbo.use()
            dst.fbo.viewport = (0, 0, frame.width, frame.height)
            source.use(0)
            self.ping["c"].use(1)
            set_uniform(prog, "current", 0)
            set_uniform(prog, "history", 1)
            set_uniform(prog, "weight", 1.0 / (self.count + 1))
            if reprojection is not None:
                reprojection.use(2)
                set_uniform(prog, "reprojection", 2)
                set_uniform(prog, "max_count", float(max_frames))
                # after a reset the history texture holds another image (or a frame the backend
                # accumulated itself: Backend.present), unless the camera moved and the mean goes on
                set_uniform(prog, "restart", int(self.count == 0 and not frame.moved))
            vao.render(vertices=3)
        self.ping, self.pong = self.pong, self.ping
        self.count += 1
        frame.channels["accumulated"] = self.ping["c"]

    def release(self) -> None:
        self.ping.release()
        self.pong.release()


class DisplayPass(Pass):
    """Exposure + ACES + sRGB (or a data channel's display mapping), then FXAA on the forward
    and hybrid modes' images."""

    name = "display"
    reads = ("accumulated",)
    writes = ("display",)

    def __init__(self, ctx):
        self.ctx = ctx
        self.mapped = Targets(ctx, {"c": (4, "f1")})
        self.final = Targets(ctx, {"c": (4, "f1")})

    def execute(self, frame) -> None:
        source, exposure = frame.channels["accumulated"], frame.options.get("exposure")
        fxaa = frame.mode in ("forward", "hybrid") and frame.options.get("forward.fxaa")
        data_mapping = display_mapping(frame.mode, frame.scene, frame.camera) if frame.mode in CHANNEL_VIEWS else None
        mapped = self.mapped.ensure(frame.width, frame.height)
        prog, vao = fullscreen(self.ctx, "tonemap.frag")
        with frame.profiler.gpu(self.ctx, "tonemap"):
            mapped.fbo.use()
            mapped.fbo.viewport = (0, 0, frame.width, frame.height)
            source.use(0)
            set_uniform(prog, "hdr", 0)
            set_uniform(prog, "exposure", float(exposure))
            set_uniform(prog, "mode", 0 if data_mapping is None else 1)
            scale, bias = data_mapping or ((1.0, 1.0, 1.0), (0.0, 0.0, 0.0))
            set_uniform(prog, "data_scale", tuple(map(float, scale)))
            set_uniform(prog, "data_bias", tuple(map(float, bias)))
            vao.render(vertices=3)
        out = mapped["c"]
        if fxaa:
            final = self.final.ensure(frame.width, frame.height)
            fprog, fvao = fullscreen(self.ctx, "fxaa.frag")
            out.filter = (self.ctx.LINEAR, self.ctx.LINEAR)
            with frame.profiler.gpu(self.ctx, "fxaa"):
                final.fbo.use()
                final.fbo.viewport = (0, 0, frame.width, frame.height)
                out.use(0)
                set_uniform(fprog, "ldr", 0)
                fvao.render(vertices=3)
            out = final["c"]
        frame.channels["display"] = out

    def release(self) -> None:
        self.mapped.release()
        self.final.release()
