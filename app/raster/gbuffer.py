"""G-buffer pass (raster): the primary hit of every pixel, in world space."""
from __future__ import annotations

import numpy as np

from app.gl_context import set_uniform
from app.raster.targets import Targets
from core.passes import Pass

CHANNELS = {
    "g_position": (4, "f4"),  # xyz, linear depth
    "g_normal": (4, "f4"),  # shading normal, roughness
    "g_albedo": (4, "f4"),  # albedo, metallic
    "g_emissive": (4, "f4"),  # emitted radiance, material id
    "g_face": (4, "f4"),  # face normal, coverage
    "g_motion": (2, "f4"),  # pixels moved since the previous frame
}


class GBufferPass(Pass):
    name = "gbuffer"
    writes = tuple(CHANNELS) + ("depth",)

    def __init__(self, ctx):
        self.ctx = ctx
        self.targets = Targets(ctx, CHANNELS, depth=True)

    def execute(self, frame) -> None:
        t = self.targets.ensure(frame.width, frame.height)
        prog, vao = frame.gpu.vao("geometry.vert", "gbuffer.frag")
        with frame.profiler.gpu(self.ctx, "gbuffer"):
            t.fbo.use()
            t.fbo.viewport = (0, 0, frame.width, frame.height)
            t.fbo.clear(0.0, 0.0, 0.0, 0.0, depth=1.0)
            self.ctx.enable(self.ctx.DEPTH_TEST)
            self.ctx.disable(self.ctx.CULL_FACE)
            frame.gpu.bind_materials(prog)
            set_uniform(prog, "view_proj", frame.view_proj().T.astype(np.float32))
            set_uniform(prog, "prev_view_proj", frame.view_proj(frame.prev_camera).T.astype(np.float32))
            right, up, fwd = frame.camera.basis()
            set_uniform(prog, "eye", tuple(map(float, frame.camera.eye)))
            for name, v in (("cam_right", right), ("cam_up", up), ("cam_forward", fwd)):
                set_uniform(prog, name, tuple(map(float, v)))
            set_uniform(prog, "tan_half", float(np.tan(np.radians(frame.camera.fov) / 2)))
            set_uniform(prog, "viewport", (float(frame.width), float(frame.height)))
            set_uniform(prog, "jitter_ndc", frame.jitter_ndc())
            set_uniform(prog, "jitter_px", tuple(map(float, frame.jitter)))
            frame.gpu.vbo_pos.bind_to_storage_buffer(6)  # the triangles' planes (gbuffer.frag: plane_depth)
            frame.gpu.ibo.bind_to_storage_buffer(7)
            vao.render()
            self.ctx.disable(self.ctx.DEPTH_TEST)
        for name in CHANNELS:
            frame.channels[name] = t[name]
        frame.channels["depth"] = t.depth

    def release(self) -> None:
        self.targets.release()
