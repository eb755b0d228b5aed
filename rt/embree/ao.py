"""Ray-traced ambient occlusion: cosine-weighted rays of length `radius`; AO is the fraction
that escape (1 = fully open)."""
from __future__ import annotations

import numpy as np
from numba import njit, prange

from rt.embree import gather, raygen


@njit(cache=True, error_model="numpy", nogil=True, parallel=True)
def ao_frame(workers, G, base, rays, eps, radius, tr, pix, albedo, grey, view_dir, env, out, ao_image):
    """The whole AO pass in one call: blocks of points split among workers (raygen.next_block), each
    sampling its cosine-weighted rays (raygen.hemisphere_live), tracing them and counting those
    that escape, then writing its pixels, and the uncovered ones around them
    (gather.fill_uncovered; env: gather.env_args; tr: the tracing target, rtcore.target).
    Returns the rays traced."""
    n = pix.shape[0]
    env_kind, env_color, horizon, zenith, ground = env
    handle, log, logged = tr
    bounds = raygen.block_bounds(n, workers)
    counter = np.zeros(1, np.int64)  # blocks taken (raygen.next_block)
    traced = np.zeros(workers, np.int64)  # by each worker (a scalar summed across this prange came out 0)
    for w in prange(workers):  # each takes blocks until none is left
        trw = (handle, log, logged)
        while True:
            b0, b1 = raygen.next_block(counter, bounds)
            if b0 >= n:
                break
            o, d, t, _, idx = raygen.no_rays()
            kb = raygen.block_keys(pix, b0, b1, base)
            count = np.zeros(b1 - b0, np.float32)
            acc = count.reshape((b1 - b0, 1))
            for r in range(rays):
                traced[w] += raygen.hemisphere_live(G, b0, kb, 2 * r, eps, radius, o, d, t, idx, trw, acc)
            gather.write_ao(out, ao_image, pix[b0:b1], count, rays, albedo[b0:b1], grey)
            gather.fill_uncovered(out, ao_image, np.float32(1.0), pix, b0, b1, view_dir,
                                  (env_kind, env_color, horizon, zenith, ground))
    return traced.sum()


def trace(rf) -> dict:
    """The AO pass over the frame's G-buffer (one compiled call): radiance, and rt_ao (the
    fraction of rays that escape) when asked."""
    grey, rays = rf.options.get("ao.greyscale"), rf.options.get("ao.rays_per_pixel")
    out, ao_image = rf.frame_outputs(1, fill=1.0, name="rt_ao")
    radius = np.float32(rf.options.get("ao.radius"))
    rf.tracer.rays_traced += rf.tracer.run_parallel(
        ao_frame, rf.gb.soa, rf.key_base(2), rays, rf.data.eps, radius, rf.tracer.frame_target(), rf.gb.index,
        rf.gb.surface.albedo, grey, rf.gb.view_dir, gather.env_args(rf.environment), out, ao_image)
    return rf.outputs(out, rt_ao=ao_image)
