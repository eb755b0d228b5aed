"""Procedural textures for the built-in scenes (linear RGB float32, generated, no downloads)."""
import numpy as np


def carpet(size: int = 256) -> np.ndarray:
    """Dark arcade carpet with bright confetti shapes."""
    rng = np.random.default_rng(7)
    y, x = np.mgrid[0:size, 0:size] / size
    base = np.empty((size, size, 3), np.float32)
    base[:] = (0.05, 0.04, 0.12)
    palette = np.array([[0.9, 0.2, 0.5], [0.2, 0.7, 0.9], [0.95, 0.8, 0.2], [0.3, 0.9, 0.3]], np.float32)
    for _ in range(60):
        cx, cy, r = rng.random(), rng.random(), 0.02 + 0.03 * rng.random()
        dx = np.minimum(abs(x - cx), 1 - abs(x - cx))
        dy = np.minimum(abs(y - cy), 1 - abs(y - cy))
        ring = np.abs(np.hypot(dx, dy) - r) < 0.006
        base[ring] = palette[rng.integers(len(palette))]
    return base


def checker(size: int = 128, tiles: int = 8, a=(0.8, 0.8, 0.8), b=(0.2, 0.2, 0.2)) -> np.ndarray:
    y, x = np.mgrid[0:size, 0:size] * tiles // size
    mask = ((x + y) % 2 == 0)[..., None]
    return np.where(mask, np.asarray(a, np.float32), np.asarray(b, np.float32)).astype(np.float32)


def cobbles(size: int = 256) -> np.ndarray:
    """Grey paving stones with darker joints."""
    rng = np.random.default_rng(3)
    y, x = np.mgrid[0:size, 0:size]
    cell = 32
    row = y // cell
    xo = (x + (row % 2) * cell // 2) // cell
    tone = rng.uniform(0.25, 0.4, (size // cell + 2, size // cell + 2))[row, xo]
    joint = ((y % cell) < 2) | (((x + (row % 2) * cell // 2) % cell) < 2)
    v = np.where(joint, 0.08, tone).astype(np.float32)
    return np.stack([v, v * 0.97, v * 0.92], -1)


def grass(size: int = 256) -> np.ndarray:
    rng = np.random.default_rng(5)
    noise = rng.random((size, size)).astype(np.float32)
    k = np.ones(5, np.float32) / 5
    for axis in (0, 1):
        noise = np.apply_along_axis(lambda r: np.convolve(np.concatenate([r[-2:], r, r[:2]]), k, "valid"),
                                    axis, noise)
    g = 0.6 + 0.8 * (noise - noise.mean())
    return np.stack([0.08 * g, 0.22 * g, 0.05 * g], -1).astype(np.float32)


def marble(size: int = 256) -> np.ndarray:
    """White marble with soft grey veins."""
    y, x = np.mgrid[0:size, 0:size] / size * 2 * np.pi
    vein = np.sin(3 * x + 2.5 * np.sin(2 * y) + 1.3 * np.sin(5 * x + 3 * y))
    v = 0.8 - 0.12 * np.exp(-40 * vein**2)
    return np.stack([v, v * 0.98, v * 0.95], -1).astype(np.float32)
