"""Render targets that follow the frame size, reused across frames."""
from __future__ import annotations


class Targets:
    """A set of same-sized textures (+ optional depth) recreated only on resize."""

    def __init__(self, ctx, specs: dict, depth: bool = False, shared_depth=None):
        self.ctx, self.specs, self.want_depth, self.shared_depth = ctx, specs, depth, shared_depth
        self.size = None
        self.textures: dict = {}
        self.depth = None
        self.fbo = None

    def ensure(self, width: int, height: int, shared_depth=None):
        if shared_depth is not None and shared_depth is not self.shared_depth:
            self.shared_depth = shared_depth
            self.size = None
        if self.size == (width, height):
            return self
        self.release()
        for name, (components, dtype) in self.specs.items():
            tex = self.ctx.texture((width, height), components, dtype=dtype)
            tex.filter = (self.ctx.NEAREST, self.ctx.NEAREST)
            tex.repeat_x = tex.repeat_y = False
            self.textures[name] = tex
        depth = self.shared_depth
        if depth is None and self.want_depth:
            depth = self.depth = self.ctx.depth_texture((width, height))
        self.fbo = self.ctx.framebuffer(list(self.textures.values()), depth)
        self.size = (width, height)
        return self

    def __getitem__(self, name):
        return self.textures[name]

    def release(self) -> None:
        for tex in self.textures.values():
            tex.release()
        self.textures = {}
        if self.depth is not None:
            self.depth.release()
            self.depth = None
        if self.fbo is not None:
            self.fbo.release()
            self.fbo = None
        self.size = None
