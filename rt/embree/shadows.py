"""Ray-traced shadows: a shadow ray to every light per pixel (`all`), or to one light per
pixel chosen by its contribution there (`one`, unbiased: accumulates to `all`)."""
from __future__ import annotations

import numpy as np
from numba import prange

from rt.embree import brdf, gather, raygen
from rt.embree.jit import njit


@njit(cache=True, error_model="numpy", nogil=True, parallel=True)
def shadows_frame(workers, scene, frame, base, one, grey, ggx):
    """The whole shadows pass in one call (scene, frame: kernel_args.SceneArgs, FrameArgs; base:
    RtFrame.key_base). Blocks of points split among workers, each block: sample a shadow ray to
    every light (or to one light picked by its contribution: `one`), trace it, add the light of
    those that get through (raygen.direct_block); then the block's pixels (grey: light alone),
    its irradiance into frame.aux (ggx: its direct radiance, brdf.py), and the uncovered pixels
    around them. Returns the rays traced."""
    pix = frame.pix
    n = pix.shape[0]
    bounds = raygen.block_bounds(n, workers)
    counter = np.zeros(1, np.int64)  # blocks taken (raygen.next_block)
    traced = np.zeros(workers, np.int64)  # by each worker (a scalar summed across this prange came out 0)
    for w in prange(workers):  # each takes blocks until none is left
        while True:
            b0, b1 = raygen.next_block(counter, bounds)
            if b0 >= n:
                break
            keys = raygen.block_keys(pix, b0, b1, base)
            irradiance = brdf.accumulator(ggx, frame.view_dir, pix[b0:b1], frame.roughness[b0:b1])
            traced[w] += raygen.direct_block(frame.points, b0, keys, scene.lights, one, 0, scene.far,
                                             frame.target, irradiance)
            albedo, metallic = frame.albedo[b0:b1], frame.metallic[b0:b1]
            gather.write_lit(frame.out, pix[b0:b1], frame.emissive[b0:b1], albedo, metallic, irradiance, None, grey)
            if frame.aux.shape[0] > 0:
                gather.put_rows(frame.aux, pix[b0:b1],
                                gather.direct_radiance(irradiance, albedo, metallic) if ggx else irradiance)
            gather.fill_uncovered(frame.out, frame.aux, np.float32(0.0), pix, b0, b1, frame.view_dir, frame.env)
    return traced.sum()


def trace(rf) -> dict:
    """The shadows pass over the frame's G-buffer (one compiled call): radiance, and rt_direct
    (irradiance x cos; with GGX the direct radiance) when asked."""
    out, direct = rf.frame_outputs(name="rt_direct")
    rf.tracer.rays_traced += rf.tracer.run_parallel(
        shadows_frame, rf.data.kernel_scene, rf.kernel_frame(out, direct), rf.key_base(1),
        rf.options.get("shadows.lights") == "one", rf.options.get("shadows.greyscale"), rf.ggx)
    return rf.outputs(out, rt_direct=direct)
