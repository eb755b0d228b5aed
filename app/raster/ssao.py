"""SSAO pass: the raster counterpart of RT ambient occlusion."""
from __future__ import annotations

import numpy as np

from app.gl_context import bind_channels, fullscreen, set_uniform
from app.raster.targets import Targets
from core.passes import Pass


def ssao_kernel(n: int = 64, seed: int = 0) -> np.ndarray:
    """Hemisphere samples (z up), denser near the centre."""
    rng = np.random.default_rng(seed)
    v = rng.normal(size=(n, 3))
    v[:, 2] = np.abs(v[:, 2])
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    scale = 0.1 + 0.9 * (np.arange(n) / n) ** 2
    return (v * (rng.random((n, 1)) ** 0.5) * scale[:, None]).astype(np.float32)


class SSAOPass(Pass):
    """Screen-space AO for the forward pass's ambient term; off when a ray-traced input
    (rt_ao, rt_indirect) already holds the occlusion."""

    name = "ssao"
    reads = ("g_position", "g_normal", "g_face")
    writes = ("ssao",)

    def __init__(self, ctx):
        self.ctx = ctx
        self.raw = Targets(ctx, {"ao": (1, "f2")})
        self.blurred = Targets(ctx, {"ao": (1, "f2")})
        rng = np.random.default_rng(1)
        noise = rng.random((4, 4, 3)).astype("f4")
        noise[..., 2] = 0.5
        self.noise = ctx.texture((4, 4), 3, noise.tobytes(), dtype="f4")
        self.noise.filter = (ctx.NEAREST, ctx.NEAREST)
        self.kernel = ssao_kernel()

    def execute(self, frame) -> None:
        opts = frame.options.group("forward")
        if not opts.ssao or "rt_ao" in frame.channels or "rt_indirect" in frame.channels:
            return
        raw = self.raw.ensure(frame.width, frame.height)
        prog, vao = fullscreen(self.ctx, "ssao.frag")
        with frame.profiler.gpu(self.ctx, "ssao"):
            raw.fbo.use()
            raw.fbo.viewport = (0, 0, frame.width, frame.height)
            bind_channels(prog, frame, ("g_position", "g_normal", "g_face"))
            self.noise.use(3)
            set_uniform(prog, "noise", 3)
            set_uniform(prog, "kernel", self.kernel)
            set_uniform(prog, "samples", int(opts.ssao_samples))
            set_uniform(prog, "radius", float(opts.ssao_radius))
            set_uniform(prog, "view_proj", frame.view_proj().T.astype(np.float32))
            _, _, fwd = frame.camera.basis()
            set_uniform(prog, "eye", tuple(map(float, frame.camera.eye)))
            set_uniform(prog, "cam_forward", tuple(map(float, fwd)))
            vao.render(vertices=3)
            out = raw["ao"]
            if opts.ssao_blur:
                blurred = self.blurred.ensure(frame.width, frame.height)
                bprog, bvao = fullscreen(self.ctx, "ssao_blur.frag")
                blurred.fbo.use()
                blurred.fbo.viewport = (0, 0, frame.width, frame.height)
                raw["ao"].use(0)
                set_uniform(bprog, "ao_raw", 0)
                bvao.render(vertices=3)
                out = blurred["ao"]
        frame.channels["ssao"] = out

    def release(self) -> None:
        self.raw.release()
        self.blurred.release()
        self.noise.release()
