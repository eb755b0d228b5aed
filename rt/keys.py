"""The frame's random-number keys, the same on every backend: a pixel's numbers are a hash
of (seed, frame, pixel, dimension), so the same command gives the same image, and two backends
given the same frame draw the same numbers (rt/embree/kernels.py: pixel_key, uniform;
shaders/rt/common.slang: the same functions)."""
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


def key_base(seed: int, frame: int, stream: int) -> np.uint64:
    """What a pixel's key hashes its id with (kernels.pixel_key): one per seed, frame and stream."""
    with np.errstate(over="ignore"):
        return _mix(np.uint64(seed & 0xFFFFFFFF) * _GOLDEN + np.uint64(frame & 0xFFFFFFFF)
                    + np.uint64(stream) * np.uint64(0x632BE59BD9B4E019))
