"""G-buffer packing for the CPU (raster): the five RGBA32F targets the ray-traced passes start
from, packed on the GPU into 32 bytes a pixel (shaders/gbuffer_pack.frag) before the
readback, instead of the 80 bytes a pixel of the targets themselves."""
from __future__ import annotations

import numpy as np

from app.gl_context import bind_channels, fullscreen
from app.raster.targets import Targets
from core.passes import Pass

SOURCES = ("g_position", "g_normal", "g_albedo", "g_emissive", "g_face")


class GBufferPackPass(Pass):
    """The G-buffer packed in two integer targets and read back for a ray-tracing backend."""

    name = "gbuffer_pack"
    reads = SOURCES
    writes = ("gbuffer_packed",)

    def __init__(self, ctx):
        self.ctx = ctx
        self.targets = Targets(ctx, {"geometry": (4, "u4"), "material": (4, "u4")})

    def execute(self, frame) -> None:
        t = self.targets.ensure(frame.width, frame.height)
        prog, vao = fullscreen(self.ctx, "gbuffer_pack.frag")
        with frame.profiler.gpu(self.ctx, "gbuffer_pack"):
            t.fbo.use()
            t.fbo.viewport = (0, 0, frame.width, frame.height)
            bind_channels(prog, frame, SOURCES)
            vao.render(vertices=3)
        if frame.interop is not None:  # into memory the ray-tracing device shares: no host copy
            with frame.profiler.cpu("gbuffer_share"):
                frame.channels["gbuffer_packed"] = self.share(frame)
            return
        with frame.profiler.cpu("gbuffer_readback"):
            frame.channels["gbuffer_packed"] = self.read()

    def share(self, frame) -> dict:
        """The packed targets copied on the GPU into memory shared with the backend's device (as
        GL stores them: bottom row first); returns the device's buffers."""
        links = {}
        for name in ("geometry", "material"):
            links[name] = frame.interop.link(f"gbuffer.{name}", 16 * frame.width * frame.height)
            self.targets[name].read_into(links[name].gl)
        frame.interop.to_device(list(links.values()))
        return {name: link.device for name, link in links.items()}

    def read(self) -> dict:
        """The packed targets as GL stores them (bottom row first): uint32 H x W x 4 each."""
        out = {}
        for name, comps in (("geometry", 4), ("material", 4)):
            tex = self.targets[name]
            w, h = tex.size
            out[name] = np.frombuffer(tex.read(), np.uint32).reshape(h, w, comps)
        return out

    def release(self) -> None:
        self.targets.release()
