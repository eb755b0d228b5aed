"""G-buffer channel views: `--pass albedo|normal|position|depth|roughness|metallic|emissive|motion`."""
from __future__ import annotations

import numpy as np

from app.gl_context import bind_channels, fullscreen, set_uniform
from app.raster.targets import Targets
from core.passes import Pass

CHANNEL_VIEWS = ("albedo", "normal", "position", "depth", "roughness", "emissive", "motion", "metallic")
SOURCES = ("g_position", "g_normal", "g_albedo", "g_emissive", "g_face", "g_motion")


def display_mapping(channel: str, scene, camera) -> tuple | None:
    """How a data channel is shown: value * scale + bias (None: shown as radiance)."""
    if channel in ("albedo", "roughness", "metallic"):
        return (1, 1, 1), (0, 0, 0)
    if channel == "normal":
        return (0.5, 0.5, 0.5), (0.5, 0.5, 0.5)
    if channel == "position":
        lo, hi = scene.bounds()
        scale = 1.0 / np.maximum(hi - lo, 1e-6)
        return tuple(scale), tuple(-lo * scale)
    if channel == "depth":
        s = 1.0 / max(scene.diagonal, 1e-6)
        return (s, s, s), (0, 0, 0)
    if channel == "motion":
        return (0.05, 0.05, 0.0), (0.5, 0.5, 0.0)
    return None  # emissive: radiance


class ChannelViewPass(Pass):
    """The G-buffer channel the mode names (frame.mode: albedo, normal, ...), as radiance."""

    name = "channel_view"
    reads = SOURCES
    writes = ("radiance",)

    def __init__(self, ctx):
        self.ctx = ctx
        self.targets = Targets(ctx, {"v": (4, "f4")})

    def execute(self, frame) -> None:
        channel = frame.mode
        t = self.targets.ensure(frame.width, frame.height)
        prog, vao = fullscreen(self.ctx, "channel_view.frag")
        with frame.profiler.gpu(self.ctx, "channel_view"):
            t.fbo.use()
            t.fbo.viewport = (0, 0, frame.width, frame.height)
            bind_channels(prog, frame, SOURCES)
            set_uniform(prog, "channel", CHANNEL_VIEWS.index(channel))
            vao.render(vertices=3)
        frame.channels["radiance"] = t["v"]

    def release(self) -> None:
        self.targets.release()
