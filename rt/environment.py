"""The environment (radiance of rays that miss) as every backend's kernels take it."""
from __future__ import annotations

import numpy as np

from scenes.model import GRADIENTS

_NO_MAP = np.zeros((1, 1, 3), np.float32)


def env_args(environment) -> tuple:
    """An environment as kernel arguments (the Embree kernels; common.slang's Environment): kind
    (0 black, 1 constant colour, 2 an analytic gradient of scenes/model.py: the sky or the
    studio, 3 an equirectangular map), colour (the gradient's strength in [0]; a map's strength
    and rotation as a shift of u, scenes/model.py equirect_uv, in [0] and [1]), the gradient's
    horizon, zenith and ground colours (the sky's for the kinds without one) and the map's
    texels (H, W, 3) float32 (one black texel for the other kinds)."""
    kind = {"black": 0, "constant": 1, "sky": 2, "studio": 2, "map": 3}[environment.kind]
    if kind == 3:
        color = np.asarray((environment.strength, environment.rotation_u, 0), np.float32)
    else:
        color = np.asarray(environment.color if kind == 1 else (environment.strength, 0, 0), np.float32)
    texels = environment.pixels if kind == 3 else _NO_MAP
    return (kind, color, *GRADIENTS.get(environment.kind, GRADIENTS["sky"]), texels)


# ---- sampling a map by importance (the reference's and the shadows pass's environment samples) ----

MAX_CELLS_U = 1024  # a map's distribution: its luminance averaged over blocks to at most this many columns
_TWO_PI2 = np.float32(2 * np.pi * np.pi)


class EnvDistribution:
    """A piecewise-constant density over an equirectangular grid (u, v) of width x height cells
    (scenes/model.py equirect_uv, before the rotation): cell c drawn with probability
    cdf[c + 1] - cdf[c] (float32, as every backend reads it), its weight the luminance of the
    environment there times sin(theta), then a point uniform in the cell. Its density per solid
    angle at a direction of polar angle theta in cell c: P(c) W H / (2 pi^2 sin(theta))."""

    def __init__(self, weights: np.ndarray):
        self.height, self.width = weights.shape
        c = np.concatenate(([0.0], np.cumsum(weights.reshape(-1), dtype=np.float64)))
        self.cdf = np.ascontiguousarray(c / c[-1], np.float32)
        self.cdf[-1] = 1.0

    def sample(self, u1: np.ndarray, u2: np.ndarray, rotation_u: float) -> tuple[np.ndarray, np.ndarray]:
        """Directions (N,3) float32 for uniform numbers u1 (the cell, then the offset in u) and u2
        (the offset in v), and their densities (N,) per solid angle."""
        cdf, w, h = self.cdf, self.width, self.height
        u1, u2 = u1.astype(np.float32), u2.astype(np.float32)
        cell = np.clip(np.searchsorted(cdf, u1, side="right") - 1, 0, w * h - 1)
        prob = cdf[cell + 1] - cdf[cell]
        fx = np.clip((u1 - cdf[cell]) / np.where(prob > 0, prob, np.float32(1)), 0, np.float32(0.99999994))
        u = ((cell % w) + fx) / np.float32(w) - np.float32(rotation_u)
        theta = np.float32(np.pi) * (((cell // w) + u2) / np.float32(h))
        phi = np.float32(2 * np.pi) * u
        st = np.sin(theta)
        dirs = np.stack([st * np.sin(phi), np.cos(theta), -st * np.cos(phi)], axis=1).astype(np.float32)
        return dirs, self._density(prob, st)

    def pdf(self, dirs: np.ndarray, rotation_u: float) -> np.ndarray:
        """The density per solid angle with which sample() draws unit directions dirs (N,3)."""
        from scenes.model import equirect_uv

        u, v = equirect_uv(dirs.astype(np.float32), rotation_u)
        col = np.minimum((u * self.width).astype(np.int64), self.width - 1)
        row = np.minimum((v * self.height).astype(np.int64), self.height - 1)
        cell = row * self.width + col
        st = np.sqrt(np.maximum(np.float32(1) - np.clip(dirs[:, 1], -1, 1).astype(np.float32) ** 2, 0))
        return self._density(self.cdf[cell + 1] - self.cdf[cell], st)

    def _density(self, prob: np.ndarray, sin_theta: np.ndarray) -> np.ndarray:
        area = np.float32(self.width * self.height) / _TWO_PI2
        return (prob * area / np.maximum(sin_theta, np.float32(1e-6))).astype(np.float32)


_DISTRIBUTIONS: list = []  # (a map's array, its distribution): the last few made


def env_distribution(environment) -> EnvDistribution | None:
    """A map's sampling distribution, from its luminance (filtered as GL's bilinear lookup reads
    it, then averaged over blocks of texels when it is wider than MAX_CELLS_U), made once per
    map; None for a map with no light and for the analytic environments (smooth: the bounces
    that escape to them sample them well)."""
    if environment.kind != "map":
        return None
    for pixels, dist in _DISTRIBUTIONS:
        if pixels is environment.pixels:
            return dist
    lum = _luminance_grid(environment)
    h, w = lum.shape
    sin_theta = np.sin((np.arange(h) + 0.5) / h * np.pi)[:, None]
    weights = np.maximum(lum, 0) * sin_theta
    dist = EnvDistribution(weights) if weights.sum() > 0 and np.isfinite(weights.sum()) else None
    _DISTRIBUTIONS.insert(0, (environment.pixels, dist))
    del _DISTRIBUTIONS[4:]
    return dist


def _luminance_grid(environment) -> np.ndarray:
    from rt.lights import LUMA

    lum = environment.pixels.astype(np.float64) @ LUMA.astype(np.float64)
    # each texel's cell: the mean over it of the map's bilinear radiance (1/8, 3/4, 1/8 of the texels
    # before, at and after it in u, wrapping, and in v, clamped), so that no part of the cell is
    # much brighter than its density allows
    lum = 0.75 * lum + 0.125 * (np.roll(lum, 1, axis=1) + np.roll(lum, -1, axis=1))
    lum = 0.75 * lum + 0.125 * (np.concatenate([lum[:1], lum[:-1]]) + np.concatenate([lum[1:], lum[-1:]]))
    f = -(-lum.shape[1] // MAX_CELLS_U)
    if f > 1:  # block means, the edges repeated to whole blocks
        h, w = -(-lum.shape[0] // f) * f, -(-lum.shape[1] // f) * f
        lum = np.pad(lum, ((0, h - lum.shape[0]), (0, w - lum.shape[1])), mode="edge")
        lum = lum.reshape(h // f, f, w // f, f).mean(axis=(1, 3))
    return lum


_NO_DISTRIBUTION = (np.array([0.0, 1.0], np.float32), np.int64(0), np.int64(0))


def env_dist_args(environment) -> tuple:
    """A map's distribution as the Embree kernels take it (rt/embree/env_light.py): (cdf,
    cells u, cells v); cells 0 where the environment is not sampled by importance."""
    dist = env_distribution(environment)
    return _NO_DISTRIBUTION if dist is None else (dist.cdf, np.int64(dist.width), np.int64(dist.height))
