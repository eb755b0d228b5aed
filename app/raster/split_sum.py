"""The raster baseline's image-based specular light under glTF's BRDF, as the glTF sample viewer
does it: the split-sum approximation (Karis 2013). The environment's radiance prefiltered by
GGX lobes of a few roughnesses (specular_maps: equirectangular, one layer per roughness, with
n = v = r, the reflection direction), times a lookup table of the BRDF's directional albedo
split into its Fresnel terms (brdf_lut: f0 A + B, by n.v and roughness). Its known error: the
lobe's shape does not change with the view angle (no stretching at grazing angles) and
multiple scattering is left out, as in the sample viewer. Built once per environment on the
host (shaders/forward.frag reads them)."""
from __future__ import annotations

import functools

import numpy as np

SPECULAR_LEVELS = 6  # roughness 0, 0.2, .. 1: layer k has roughness k / (SPECULAR_LEVELS - 1)
SPECULAR_SIZE = (64, 32)  # each layer's texels (u, v)
LUT_SIZE = 32
MIN_ALPHA = 1e-3  # rt/embree/brdf.py's


def _g1(c, a):
    c = np.maximum(c, 1e-4)
    return 2 * c / (c + np.sqrt(a * a + (1 - a * a) * c * c))


@functools.lru_cache(maxsize=1)
def brdf_lut(size: int = LUT_SIZE, samples: int = 1024) -> np.ndarray:
    """(size, size, 2) float32, rows by roughness and columns by n.v (texel centres): A and B
    of the specular lobe's directional albedo f0 A + B, GGX (alpha = roughness^2) with Smith's
    separable G as rtlab's passes, integrated with half vectors drawn from D (stratified)."""
    nv = (np.arange(size) + 0.5) / size
    rough = (np.arange(size) + 0.5) / size
    a = np.maximum(rough * rough, MIN_ALPHA)[:, None, None]
    u = (np.arange(samples) + 0.5) / samples
    phi = 2 * np.pi * ((np.arange(samples) * 0.6180339887498949) % 1.0)  # a golden-ratio sequence
    cos_h = np.sqrt((1 - u) / (1 + (a * a - 1) * u))  # D-distributed half vectors: (roughness, 1, sample)
    sin_h = np.sqrt(1 - cos_h * cos_h)
    v = np.stack([np.sqrt(1 - nv * nv), np.zeros_like(nv), nv], -1)[None, :, None, :]  # (1, nv, 1, 3)
    h = np.stack([sin_h * np.cos(phi), sin_h * np.sin(phi), cos_h], -1)  # (roughness, 1, sample, 3)
    vh = (v * h).sum(-1)
    lz = 2 * vh * h[..., 2] - v[..., 2]  # n.l of v reflected about h
    g_vis = np.where((lz > 0) & (vh > 0), _g1(nv[None, :, None], a) * _g1(lz, a) * vh / (h[..., 2] * nv[None, :, None]),
                     0.0)
    fc = (1 - np.clip(vh, 0, 1)) ** 5
    return np.stack([((1 - fc) * g_vis).mean(-1), (fc * g_vis).mean(-1)], -1).astype(np.float32)


def _area_resample(a: np.ndarray, n: int, axis: int) -> np.ndarray:
    """a resampled to n cells along axis by the mean over each (box filter: no light of a small
    bright sun is lost, as point sampling a large map would)."""
    m = a.shape[axis]
    c = np.concatenate([np.zeros_like(np.take(a, [0], axis)), np.cumsum(a, axis=axis)], axis)
    edges = np.linspace(0, m, n + 1)
    lo = np.floor(edges).astype(np.int64).clip(0, m - 1)
    frac = (edges - lo).reshape([-1 if i == axis else 1 for i in range(a.ndim)])
    take = lambda i: np.take(c, i, axis)  # noqa: E731
    at = take(lo) + frac * (take(np.minimum(lo + 1, m)) - take(lo))  # the running sum at each edge
    return np.diff(at, axis=axis) / (m / n)


def radiance_grid(env, rows: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The environment on a (rows x 2 rows) grid of directions: directions (N,3), radiance
    (N,3) (a map's averaged over each cell, the others' at its centre) and solid angles (N,)."""
    theta = (np.arange(rows) + 0.5) / rows * np.pi
    u = (np.arange(2 * rows) + 0.5) / (2 * rows)
    th, uu = np.meshgrid(theta, u, indexing="ij")
    st = np.sin(th)
    phi = 2 * np.pi * (uu - (env.rotation_u if env.kind == "map" else 0.0))  # a map's u turned back
    dirs = np.stack([st * np.sin(phi), np.cos(th), -st * np.cos(phi)], -1).reshape(-1, 3)
    if env.kind == "map":
        cells = _area_resample(_area_resample(env.pixels.astype(np.float64), rows, 0), 2 * rows, 1)
        radiance = cells.reshape(-1, 3) * env.strength
    else:
        radiance = env.radiance(dirs.astype(np.float32)).astype(np.float64)
    return dirs, radiance, (st * (np.pi / rows) ** 2).reshape(-1)


def specular_maps(env) -> np.ndarray:
    """(SPECULAR_LEVELS, h, w, 3) float32: per roughness, the environment's radiance averaged over
    the GGX lobe about each texel's direction r (n = v = r: weights D(n.h) n.l dw),
    equirectangular in direction space (a map's rotation already applied). Layer 0 is the
    radiance itself; each rougher layer integrates a grid of the environment fine enough for
    its lobe."""
    w, h = SPECULAR_SIZE
    theta = (np.arange(h) + 0.5) / h * np.pi
    phi = (np.arange(w) + 0.5) / w * 2 * np.pi
    th, ph = np.meshgrid(theta, phi, indexing="ij")
    r = np.stack([np.sin(th) * np.sin(ph), np.cos(th), -np.sin(th) * np.cos(ph)], -1).reshape(-1, 3)
    out = np.empty((SPECULAR_LEVELS, h * w, 3), np.float32)
    out[0] = env.radiance(r.astype(np.float32))
    for k in range(1, SPECULAR_LEVELS):
        rough = k / (SPECULAR_LEVELS - 1)
        a = max(rough * rough, MIN_ALPHA)
        rows = 128 if a < 0.1 else (64 if a < 0.3 else 32)  # the grid's spacing well inside the lobe
        dirs, radiance, omega = (x.astype(np.float32) for x in radiance_grid(env, rows))
        a = np.float32(a)
        for c0 in range(0, r.shape[0], 256):
            nl = r[c0:c0 + 256].astype(np.float32) @ dirs.T
            t = np.maximum((1 + nl) / 2, 0) * (a * a - 1) + 1  # (n.h)^2 (a^2 - 1) + 1, h halfway from r to l
            wgt = np.where(nl > 0, nl / (t * t), 0.0) * omega  # D x n.l x dw, up to D's constant
            out[k, c0:c0 + 256] = (wgt @ radiance) / np.maximum(wgt.sum(1), np.float32(1e-30))[:, None]
    return out.reshape(SPECULAR_LEVELS, h, w, 3)
