"""Reprojection (`reproject=true`): where each pixel's point was in the previous frame and
which history texels saw the same surface (shaders/reproject.frag), so that the accumulation
(app/raster/postprocess.py) carries its mean through camera motion instead of restarting."""
from __future__ import annotations

from app.gl_context import bind_channels, fullscreen, set_uniform
from app.raster.targets import Targets
from core.passes import Pass

SURFACES = ("g_position", "g_normal", "g_face")


class ReprojectPass(Pass):
    name = "reproject"
    reads = SURFACES + ("g_motion",)
    writes = ("reprojection",)

    def __init__(self, ctx):
        self.ctx = ctx
        self.map = Targets(ctx, {"where": (4, "f4")})
        self.prev = Targets(ctx, {"position": (4, "f4"), "normal": (4, "f4")})
        self.valid = False

    def set_scene(self, scene) -> None:
        self.valid = False

    def reset(self) -> None:
        self.valid = False

    def execute(self, frame) -> None:
        w, h = frame.width, frame.height
        if self.prev.size != (w, h):
            self.valid = False
        out, prev = self.map.ensure(w, h), self.prev.ensure(w, h)
        with frame.profiler.gpu(self.ctx, "reproject"):
            prog, vao = fullscreen(self.ctx, "reproject.frag")
            out.fbo.use()
            out.fbo.viewport = (0, 0, w, h)
            bind_channels(prog, frame, self.reads)
            prev["position"].use(len(self.reads))
            prev["normal"].use(len(self.reads) + 1)
            set_uniform(prog, "prev_position", len(self.reads))
            set_uniform(prog, "prev_normal", len(self.reads) + 1)
            set_uniform(prog, "moved", int(frame.moved))
            if self.valid or not frame.moved:
                vao.render(vertices=3)
            else:  # nothing kept to reproject from: every pixel restarts
                out.fbo.clear(0.0, 0.0, 0.0, 0.0)
            keep, kvao = fullscreen(self.ctx, "keep_surfaces.frag")
            prev.fbo.use()
            prev.fbo.viewport = (0, 0, w, h)
            bind_channels(keep, frame, SURFACES)
            kvao.render(vertices=3)
        self.valid = True
        frame.channels["reprojection"] = out["where"]

    def release(self) -> None:
        self.map.release()
        self.prev.release()
