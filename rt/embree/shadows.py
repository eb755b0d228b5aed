"""Ray-traced shadows: a shadow ray to every light per pixel (`all`), or to one light per
pixel chosen by its contribution there (`one`, unbiased: accumulates to `all`)."""
from __future__ import annotations

import numpy as np
from numba import njit, prange

from rt.embree import gather, raygen


@njit(cache=True, error_model="numpy", nogil=True, parallel=True)
def shadows_frame(workers, G, base, lights, one, eps, far, tr, pix, emissive, albedo, grey, view_dir, env, out,
                  direct):
    """The whole shadows pass in one call: blocks of points split among workers (raygen.next_block),
    each sampling, tracing and adding its shadow rays (raygen.direct_block: to every light, or
    to one chosen light) and writing its pixels, and the uncovered ones around them
    (gather.fill_uncovered; env: gather.env_args; tr: the tracing target, rtcore.target).
    Returns the rays traced."""
    n = pix.shape[0]
    # the loop body may not take tuples of arrays from outside (numba): unpacked here, rebuilt there
    kind, lpos, ldir, lrad, cos_out, spot_scale, cos_ang, lum = lights[0]
    start, rows, keep, alias = lights[1]
    lx, ly, lz, sx, sy, sz, glum, gcos, gscale, sun, cx, cy, cz, radius, power = lights[2]
    n_lights = lights[3]
    env_kind, env_color, horizon, zenith, ground = env
    handle, log, logged = tr
    bounds = raygen.block_bounds(n, workers)
    counter = np.zeros(1, np.int64)  # blocks taken (raygen.next_block)
    traced = np.zeros(workers, np.int64)  # by each worker (a scalar summed across this prange came out 0)
    for w in prange(workers):  # each takes blocks until none is left
        ls = ((kind, lpos, ldir, lrad, cos_out, spot_scale, cos_ang, lum), (start, rows, keep, alias),
              (lx, ly, lz, sx, sy, sz, glum, gcos, gscale, sun, cx, cy, cz, radius, power), n_lights)
        trw = (handle, log, logged)
        while True:
            b0, b1 = raygen.next_block(counter, bounds)
            if b0 >= n:
                break
            total = np.empty((b1 - b0, 3), np.float32)
            kb = raygen.block_keys(pix, b0, b1, base)
            traced[w] += raygen.direct_block(G, b0, kb, ls, one, 0, eps, far, trw, total)
            gather.write_lit(out, pix[b0:b1], emissive[b0:b1], albedo[b0:b1], total, None, grey)
            if direct.shape[0] > 0:  # wanted (RtFrame.aux_image)
                for j in range(b1 - b0):
                    p = pix[b0 + j]
                    direct[p, 0], direct[p, 1], direct[p, 2] = total[j, 0], total[j, 1], total[j, 2]
            gather.fill_uncovered(out, direct, np.float32(0.0), pix, b0, b1, view_dir,
                                  (env_kind, env_color, horizon, zenith, ground))
    return traced.sum()


def trace(rf) -> dict:
    """The shadows pass over the frame's G-buffer (one compiled call): radiance, and rt_direct
    (irradiance x cos) when asked."""
    out, direct = rf.frame_outputs(name="rt_direct")
    s, data = rf.gb.surface, rf.data
    one = rf.options.get("shadows.lights") == "one"
    rf.tracer.rays_traced += rf.tracer.run_parallel(
        shadows_frame, rf.gb.soa, rf.key_base(1), data.lights.kernel_args, one, data.eps, data.far,
        rf.tracer.frame_target(), rf.gb.index, s.emissive, s.albedo, rf.options.get("shadows.greyscale"),
        rf.gb.view_dir, gather.env_args(rf.environment), out, direct)
    return rf.outputs(out, rt_direct=direct)
