"""Per-thread scratch buffers, reused from frame to frame.

Ray buffers are needed for every chunk of every frame; allocating them anew costs page faults
that show up as a sizeable part of a frame. Each thread keeps its own buffers by name and
grows them when a larger one is asked for. A buffer is valid until the same thread asks for
the same name again: code that recurses uses a name per depth.
"""
from __future__ import annotations

import math
import threading

import numpy as np

_local = threading.local()


def buffer(name: str, shape: tuple, dtype=np.float32) -> np.ndarray:
    try:
        store = _local.store
    except AttributeError:
        store = _local.store = {}
    size = math.prod(shape)
    flat = store.get((name, dtype))
    if flat is None or flat.size < size:
        flat = store[(name, dtype)] = np.empty(max(size, int(size * 1.25), 1024), dtype)
    return flat[:size].reshape(shape)


def rays(name: str, n: int, with_light: bool = False):
    """(origins, directions, tmax, index[, light]) for up to n packed rays."""
    out = (buffer(name + ".o", (n, 3)), buffer(name + ".d", (n, 3)), buffer(name + ".t", (n,)),
           buffer(name + ".i", (n,), np.int32))
    return out + (buffer(name + ".e", (n, 3)),) if with_light else out
