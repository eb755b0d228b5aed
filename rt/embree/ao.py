"""Ray-traced ambient occlusion: cosine-weighted rays of length `radius`; AO is the fraction
that escape (1 = fully open)."""
from __future__ import annotations

import numpy as np
from numba import njit, prange

from rt.embree import gather, raygen, scratch


def ambient_occlusion(cf) -> np.ndarray:
    """How many of a chunk's ao.rays_per_pixel occlusion rays escape, per pixel (a scratch
    buffer: valid until this thread's next call)."""
    s = cf.s
    rays = cf.options.get("ao.rays_per_pixel")
    radius = np.float32(cf.options.get("ao.radius"))
    rng = cf.rng(2)
    n = len(s)
    open_count = scratch.buffer("ao.count", (n,))
    open_count.fill(0)
    o, d, t, idx = scratch.rays("ao", n)
    G = cf.soa
    scene = cf.tracer.inline_scene()  # traced (and counted) as they are made, or after
    acc = open_count.reshape(n, 1)
    for _ in range(rays):
        m = raygen.hemisphere_live(*G, rng.key, rng.reserve(2), cf.data.eps, radius, o, d, t, idx, scene, acc)
        if scene:
            cf.tracer.rays_traced += m
            continue
        blocked = cf.tracer.occluded(o[:m], d[:m], t[:m]) if m else np.zeros(0, np.bool_)
        raygen.add_open(open_count, idx, blocked, m)  # rays below the true surface count as occluded
    return open_count  # of ao.rays_per_pixel


@njit(cache=True, error_model="numpy", nogil=True, parallel=True)
def ao_frame(workers, G, base, rays, eps, radius, scene, pix, albedo, grey, view_dir, env, out, ao_image):
    """The whole AO pass in one call: blocks of points split among workers (raygen.next_block), each
    sampling, tracing and counting its rays as ambient_occlusion does (the same numbers) and
    writing its pixels, and the uncovered ones around them (gather.fill_uncovered; env:
    gather.env_args). Returns the rays traced."""
    n = pix.shape[0]
    env_kind, env_color, horizon, zenith, ground = env
    bounds = raygen.block_bounds(n, workers)
    counter = np.zeros(1, np.int64)  # blocks taken (raygen.next_block)
    traced = np.zeros(workers, np.int64)  # by each worker (a scalar summed across this prange came out 0)
    for w in prange(workers):  # each takes blocks until none is left
        while True:
            b0, b1 = raygen.next_block(counter, bounds)
            if b0 >= n:
                break
            o, d, t, _, idx = raygen.no_rays()
            kb = raygen.block_keys(pix, b0, b1, base)
            count = np.zeros(b1 - b0, np.float32)
            acc = count.reshape((b1 - b0, 1))
            for r in range(rays):
                traced[w] += raygen.hemisphere_live(G, b0, kb, 2 * r, eps, radius, o, d, t, idx, scene, acc)
            gather.write_ao(out, ao_image, pix[b0:b1], count, rays, albedo[b0:b1], grey)
            gather.fill_uncovered(out, ao_image, np.float32(1.0), pix, b0, b1, view_dir,
                                  (env_kind, env_color, horizon, zenith, ground))
    return traced.sum()


def trace(rf) -> dict:
    grey, rays = rf.options.get("ao.greyscale"), rf.options.get("ao.rays_per_pixel")
    scene = rf.tracer.frame_scene()
    if scene and rf.gb.soa is not None:  # one compiled call: no Python per chunk
        out, ao_image = rf.frame_outputs(1, fill=1.0, name="rt_ao")
        radius = np.float32(rf.options.get("ao.radius"))
        rf.tracer.rays_traced += rf.tracer.run_parallel(
            ao_frame, rf.gb.soa, rf.key_base(2), rays, rf.data.eps, radius, scene, rf.gb.index,
            rf.gb.surface.albedo, grey, rf.gb.view_dir, gather.env_args(rf.environment), out, ao_image)
        return rf.outputs(out, rt_ao=ao_image)

    out, ao_image = rf.background(), rf.aux_image(1, fill=1.0, name="rt_ao")

    def work(cf):
        gather.write_ao(out, ao_image, cf.idx, ambient_occlusion(cf), rays, cf.s.albedo, grey)

    rf.for_chunks(work, streams=(2,))
    return rf.outputs(out, rt_ao=ao_image)
