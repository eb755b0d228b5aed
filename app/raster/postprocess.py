"""Accumulation (running mean on the GPU) and display: tone mapping + FXAA to 8-bit."""
from __future__ import annotations

from app.gl_context import fullscreen, set_uniform
from app.raster.targets import Targets


class AccumulationPass:
    """Running mean of the pass output while nothing changes; reset() restarts it."""

    name = "accumulation"
    reads = ("radiance",)
    writes = ("accumulated",)

    def __init__(self, ctx):
        self.ctx = ctx
        self.ping = Targets(ctx, {"c": (4, "f4")})
        self.pong = Targets(ctx, {"c": (4, "f4")})
        self.count = 0

    def reset(self) -> None:
        self.count = 0

    def execute(self, frame, source, enabled: bool, max_frames: int = 0):
        if not enabled:
            self.count = 0
            frame.channels["accumulated"] = source
            return source
        if max_frames and self.count >= max_frames:
            frame.channels["accumulated"] = self.ping["c"]
            return self.ping["c"]
        self.ping.ensure(frame.width, frame.height)
        dst = self.pong.ensure(frame.width, frame.height)
        prog, vao = fullscreen(self.ctx, "accumulate.frag")
        with frame.profiler.gpu(self.ctx, "accumulation"):
            dst.fbo.use()
            dst.fbo.viewport = (0, 0, frame.width, frame.height)
            source.use(0)
            self.ping["c"].use(1)
            set_uniform(prog, "current", 0)
            set_uniform(prog, "history", 1)
            set_uniform(prog, "weight", 1.0 / (self.count + 1))
            vao.render(vertices=3)
        self.ping, self.pong = self.pong, self.ping
        self.count += 1
        frame.channels["accumulated"] = self.ping["c"]
        return self.ping["c"]

    def release(self) -> None:
        self.ping.release()
        self.pong.release()


class DisplayPass:
    """Exposure + ACES + sRGB (or a data channel's display mapping), then FXAA."""

    name = "tonemap"

    def __init__(self, ctx):
        self.ctx = ctx
        self.mapped = Targets(ctx, {"c": (4, "f1")})
        self.final = Targets(ctx, {"c": (4, "f1")})

    def execute(self, frame, source, exposure: float, fxaa: bool, data_mapping=None):
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
        return out

    def release(self) -> None:
        self.mapped.release()
        self.final.release()
