"""How the whole-frame kernels share a frame among their workers: blocks of points, shrinking
towards the frame's end (block_bounds), and each block's random keys made by its worker
(block_keys)."""
from __future__ import annotations

import numpy as np

from rt.embree.jit import njit
from rt.embree.kernels import pixel_key

FRAME_BLOCK = 2048, 32768  # fewest and most points per work item of the whole-frame kernels (block_size)


BLOCKS_PER_WORKER = 8


TAIL_SHARE = 2  # block_bounds: the last blocks take at most 1 / (TAIL_SHARE x workers) of what is left


@njit(cache=True, error_model="numpy")
def block_size(n, workers):
    """Points per work item of the whole-frame kernels: n / (BLOCKS_PER_WORKER x workers),
    within FRAME_BLOCK's bounds. A pass's steps run a block at a time, and larger blocks keep
    each step's data (the BVH while tracing, mesh rows while shading) in the cache longer."""
    return min(max(n // (workers * BLOCKS_PER_WORKER), FRAME_BLOCK[0]), FRAME_BLOCK[1])


@njit(cache=True, error_model="numpy")
def block_bounds(n, workers):
    """The whole-frame kernels' work items: points bounds[i]..bounds[i + 1]. Blocks of
    block_size, shrinking towards the end of the frame (each at most the points left over
    TAIL_SHARE x workers, and at least FRAME_BLOCK[0]), so that the workers finish together:
    with equal blocks, one worker could take the last block just as the others ran out of work,
    and they idled for up to a block's time."""
    size = block_size(n, workers)
    tail = TAIL_SHARE * workers
    bounds = np.empty(n // FRAME_BLOCK[0] + 2, np.int64)
    bounds[0] = 0
    count, b = 0, 0
    while b < n:
        # one worker: nobody to wait for, blocks of block_size to the end
        step = size if workers == 1 else min(size, max((n - b) // tail, FRAME_BLOCK[0]))
        b = min(b + step, n)
        count += 1
        bounds[count] = b
    return bounds[:count + 1]


@njit(cache=True, error_model="numpy")
def block_keys(pix, b0, b1, base):
    """The keys of a whole-frame kernel's block of points (pixels pix[b0:b1]), made by the
    worker that uses them (base: RtFrame.key_base): a pass over every pixel before the frame,
    and the keys' round trip through memory, saved."""
    keys = np.empty(b1 - b0, np.uint64)
    for j in range(b1 - b0):
        keys[j] = pixel_key(pix[b0 + j], base)
    return keys
