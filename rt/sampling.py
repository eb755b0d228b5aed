"""Random numbers and directions shared by every ray-traced pass.

Random numbers are a hash of (seed, frame, pixel, dimension): the same command gives the
same image, and any pixel's sequence can be reproduced on its own.
"""
from __future__ import annotations

import numpy as np

_M1 = np.uint64(0xBF58476D1CE4E5B9)
_M2 = np.uint64(0x94D049BB133111EB)
_GOLDEN = np.uint64(0x9E3779B97F4A7C15)


def _mix(x: np.ndarray) -> np.ndarray:
    """splitmix64 finaliser (wrapping uint64 arithmetic)."""
    with np.errstate(over="ignore"):
        x = (x ^ (x >> np.uint64(30))) * _M1
        x = (x ^ (x >> np.uint64(27))) * _M2
        return x ^ (x >> np.uint64(31))


class PixelRng:
    """Uniform numbers in [0,1) per pixel; `next(k)` returns k fresh dimensions."""

    def __init__(self, seed: int, frame: int, pixels: np.ndarray, stream: int = 0):
        with np.errstate(over="ignore"):
            base = _mix(np.uint64(seed & 0xFFFFFFFF) * _GOLDEN + np.uint64(frame & 0xFFFFFFFF)
                        + np.uint64(stream) * np.uint64(0x632BE59BD9B4E019))
            self.key = _mix(pixels.astype(np.uint64) * _GOLDEN + base)
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
        from rt.kernels import uniforms

        first = self.reserve(k)
        out = np.empty((self.key.shape[0], k), np.float32)
        if out.size:
            uniforms(self.key, first, k, out)
        return out

    def subset(self, index: np.ndarray) -> PixelRng:
        """The generators of some pixels (same sequences), for rays still alive."""
        r = PixelRng.__new__(PixelRng)
        r.key, r._dim = self.key[index], self._dim
        return r


def orthonormal_basis(n: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Tangent and bitangent for unit normals (N,3) (Duff et al. 2017, branchless)."""
    sign = np.where(n[:, 2] >= 0, 1.0, -1.0).astype(np.float32)
    a = -1.0 / (sign + n[:, 2])
    b = n[:, 0] * n[:, 1] * a
    t = np.stack([1 + sign * n[:, 0] ** 2 * a, sign * b, -sign * n[:, 0]], 1)
    bt = np.stack([b, sign + n[:, 1] ** 2 * a, -n[:, 1]], 1)
    return t.astype(np.float32), bt.astype(np.float32)


def cosine_hemisphere(n: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Cosine-weighted unit directions around unit normals n (N,3), from uniforms u (N,2)."""
    r = np.sqrt(u[:, 0])
    phi = np.float32(2 * np.pi) * u[:, 1]
    x, y = r * np.cos(phi), r * np.sin(phi)
    z = np.sqrt(np.maximum(0.0, 1.0 - u[:, 0]))
    t, b = orthonormal_basis(n)
    d = t * x[:, None] + b * y[:, None] + n * z[:, None]
    return d.astype(np.float32)


def uniform_cone(axis: np.ndarray, cos_max: float, u: np.ndarray) -> np.ndarray:
    """Uniform directions within a cone of half-angle acos(cos_max) around unit axes (N,3)."""
    cos_t = 1.0 - u[:, 0] * (1.0 - cos_max)
    sin_t = np.sqrt(np.maximum(0.0, 1.0 - cos_t * cos_t))
    phi = np.float32(2 * np.pi) * u[:, 1]
    t, b = orthonormal_basis(axis)
    d = t * (sin_t * np.cos(phi))[:, None] + b * (sin_t * np.sin(phi))[:, None] + axis * cos_t[:, None]
    return d.astype(np.float32)


def normalize(v: np.ndarray) -> np.ndarray:
    return (v / np.maximum(np.linalg.norm(v, axis=-1, keepdims=True), 1e-20)).astype(np.float32)
