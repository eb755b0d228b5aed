"""CPU <-> GPU image transfers for the ray-traced passes (row 0 = top on the CPU)."""
from __future__ import annotations

import numpy as np

from app.raster.targets import Targets


def read_rgba(tex) -> np.ndarray:
    """An RGBA32F texture as H x W x 4 float32, top row first."""
    w, h = tex.size
    return np.frombuffer(tex.read(), np.float32).reshape(h, w, 4)[::-1]


class Uploads:
    """Float textures that receive CPU images, one per name, reused between frames."""

    def __init__(self, ctx):
        self.ctx = ctx
        self.targets: dict[str, Targets] = {}

    def upload(self, name: str, image: np.ndarray, width: int, height: int):
        """image: (H*W, C) or (H*W,) float32 in top-row-first order; returns the texture."""
        t = self.targets.get(name)
        if t is None:
            t = self.targets[name] = Targets(self.ctx, {"c": (4, "f4")})
        tex = t.ensure(width, height)["c"]
        img = image.reshape(height, width, -1)
        rgba = np.zeros((height, width, 4), np.float32)
        c = min(img.shape[2], 4)
        rgba[..., :c] = img[..., :c]
        if c == 1:
            rgba[..., 1:3] = img[..., :1]
        if c < 4:
            rgba[..., 3] = 1.0
        tex.write(np.ascontiguousarray(rgba[::-1]).tobytes())
        return tex

    def release(self) -> None:
        for t in self.targets.values():
            t.release()
        self.targets = {}
