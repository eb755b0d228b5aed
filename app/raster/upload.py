"""CPU <-> GPU image transfers for the ray-traced passes (row 0 = top on the CPU)."""
from __future__ import annotations

import numpy as np

from app.raster.targets import Targets


def read_rgba(tex, flip: bool = True) -> np.ndarray:
    """An RGBA32F texture as H x W x 4 float32, top row first (flip=False: as GL stores it)."""
    w, h = tex.size
    data = np.frombuffer(tex.read(), np.float32).reshape(h, w, 4)
    return data[::-1] if flip else data


class Uploads:
    """Float textures that receive CPU images, one per name, reused between frames."""

    def __init__(self, ctx):
        self.ctx = ctx
        self.targets: dict[str, Targets] = {}
        self.buffers: dict[str, np.ndarray] = {}  # upload staging, reused between frames

    def upload(self, name: str, image: np.ndarray, width: int, height: int):
        """image: (H*W, C) or (H*W,) float32 in top-row-first order; returns the texture."""
        t = self.targets.get(name)
        if t is None:
            t = self.targets[name] = Targets(self.ctx, {"c": (4, "f4")})
        from rt.backends import pack_rgba_flipped

        tex = t.ensure(width, height)["c"]
        img = np.ascontiguousarray(image, np.float32).reshape(height * width, -1)
        buf = self.buffers.get(name)
        if buf is None or buf.shape[:2] != (height, width):
            buf = self.buffers[name] = np.empty((height, width, 4), np.float32)
        pack_rgba_flipped(img, height, width, min(img.shape[1], 4), buf)
        tex.write(buf)
        return tex

    def from_buffer(self, name: str, buffer, width: int, height: int):
        """A GL buffer holding an RGBA32F image as a texture upload takes it (bottom row first:
        rt/slang's export into shared memory) into the name's texture, on the GPU."""
        tex = self._target(name, "f4").ensure(width, height)["c"]
        tex.write(buffer)
        return tex

    def rgba8_from_buffer(self, name: str, buffer, width: int, height: int):
        """As from_buffer, for an RGBA8 image (rows bottom-up)."""
        tex = self._target(name, "f1").ensure(width, height)["c"]
        tex.write(buffer)
        return tex

    def _target(self, name: str, dtype: str) -> Targets:
        t = self.targets.get(name)
        if t is None:
            t = self.targets[name] = Targets(self.ctx, {"c": (4, dtype)})
        return t

    def upload_rgba8(self, name: str, image: np.ndarray):
        """image: H x W x 4 uint8, rows bottom-up as GL stores them; returns the texture."""
        h, w = image.shape[:2]
        t = self.targets.get(name)
        if t is None:
            t = self.targets[name] = Targets(self.ctx, {"c": (4, "f1")})
        tex = t.ensure(w, h)["c"]
        tex.write(np.ascontiguousarray(image))
        return tex

    def release(self) -> None:
        for t in self.targets.values():
            t.release()
        self.targets = {}
