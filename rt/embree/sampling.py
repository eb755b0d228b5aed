"""Per-pixel random numbers shared by every ray-traced pass (the kernels draw the same ones).

Random numbers are a hash of (seed, frame, pixel, dimension): the same command gives the
same image, and any pixel's sequence can be reproduced on its own.
"""
from __future__ import annotations

import numpy as np

from rt.keys import key_base  # noqa: F401  (re-exported: the Embree backend's spelling)


class PixelRng:
    """Uniform numbers in [0,1) per pixel; `next(k)` returns k fresh dimensions."""

    def __init__(self, seed: int, frame: int, pixels: np.ndarray, stream: int = 0, out: np.ndarray | None = None):
        """out: a (len(pixels),) uint64 array to hold the keys (a reused buffer), else a new one."""
        from rt.embree.kernels import pixel_keys

        base = key_base(seed, frame, stream)
        self.key = np.empty(pixels.shape[0], np.uint64) if out is None else out
        if pixels.shape[0]:
            pixel_keys(np.ascontiguousarray(pixels, np.int64), base, self.key)
        self._dim = [0]  # shared with subsets: a dimension is never used twice in a frame

    @property
    def dim(self) -> int:
        return self._dim[0]

    def reserve(self, k: int) -> int:
        """Claim k dimensions for a kernel that draws its own numbers; returns the first."""
        first = self.dim
        self._dim[0] += k
        return first

    def next(self, k: int = 1) -> np.ndarray:
        """(N,k) float32 uniforms (the same numbers the kernels draw)."""
        from rt.embree.kernels import uniforms

        first = self.reserve(k)
        out = np.empty((self.key.shape[0], k), np.float32)
        if out.size:
            uniforms(self.key, first, k, out)
        return out

    @classmethod
    def of_keys(cls, keys: np.ndarray) -> PixelRng:
        """Generators with the given keys (from another PixelRng's), counting dimensions from 0."""
        r = cls.__new__(cls)
        r.key, r._dim = keys, [0]
        return r

    def subset(self, index: np.ndarray) -> PixelRng:
        """The generators of some pixels (same sequences), for rays still alive."""
        r = PixelRng.__new__(PixelRng)
        r.key, r._dim = self.key[index], self._dim
        return r
