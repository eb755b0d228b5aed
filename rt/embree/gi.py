"""Ray-traced global illumination: direct light at the primary hit (shadowed or not, the
study's two modes) plus `rays_per_pixel` cosine-weighted bounce rays, each shaded at its hit
with one light sample and a shadow ray; `bounces` > 1 continues the path.

Light from emitters reaches bounce hits through their light samples (emissive triangles are
lights), so a bounce ray that happens to hit an emitter does not add its emission again."""
from __future__ import annotations

import numpy as np
from numba import njit, prange

from rt.embree import gather, raygen
from rt.embree import rtcore as embree
from rt.embree.kernels import shade_hits

_shade_hits = shade_hits.serial  # inside a parallel kernel's blocks




@njit(cache=True, error_model="numpy", nogil=True, parallel=True)
def gi_frame(workers, G, base, rays, bounces, shadowed, lights, eps, far, tr, env, mesh, pix, emissive, albedo,
             view_dir, out, indirect_image):
    """The whole GI pass (shadowed or not) in one call: blocks of points split among workers
    (raygen.next_block), each taking, per point: direct light from one chosen light, then per
    bounce ray a cosine ray, its closest hit, the hit's shading and its own light sample, and
    from the hit the next bounce's ray, up to `bounces`; then the pixels written, with the
    uncovered ones around them (gather.fill_uncovered). Returns the rays traced. env:
    gather.env_args; mesh: what SceneData.surface shades hits with; tr: the tracing target
    (rtcore.target). A path's light is added as it goes, times the albedos of its earlier hits
    (thr)."""
    n = pix.shape[0]
    # the loop body may not take tuples of arrays from outside (numba): unpacked here, rebuilt there
    kind, lpos, ldir, lrad, cos_out, spot_scale, cos_ang, lum = lights[0]
    start, rows, keep, alias = lights[1]
    lx, ly, lz, sx, sy, sz, glum, gcos, gscale, sun, cx, cy, cz, radius, power = lights[2]
    n_lights = lights[3]
    env_kind, env_color, horizon, zenith, ground = env
    corners, face_normals, base_color, roughness, metallic, emission, tex_offset, tex_w, tex_h, tex_data = mesh
    handle, log, logged = tr
    bounds = raygen.block_bounds(n, workers)
    counter = np.zeros(1, np.int64)  # blocks taken (raygen.next_block)
    traced = np.zeros(workers, np.int64)  # by each worker (a scalar summed across this prange came out 0)
    for w in prange(workers):  # each takes blocks until none is left
        ls = ((kind, lpos, ldir, lrad, cos_out, spot_scale, cos_ang, lum), (start, rows, keep, alias),
              (lx, ly, lz, sx, sy, sz, glum, gcos, gscale, sun, cx, cy, cz, radius, power), n_lights)
        trw = (handle, log, logged)
        lit = trw if shadowed else embree.no_trace(trw)  # no_trace: direct light unshadowed (raygen.direct_block)
        while True:
            b0, b1 = raygen.next_block(counter, bounds)
            if b0 >= n:
                break
            nb = b1 - b0
            kb = raygen.block_keys(pix, b0, b1, base)
            direct = np.empty((nb, 3), np.float32)
            traced[w] += raygen.direct_block(G, b0, kb, ls, True, 0, eps, far, lit, direct)
            total = np.zeros((nb, 3), np.float32)
            o, d, t, owner = (np.empty((nb, 3), np.float32), np.empty((nb, 3), np.float32),
                              np.empty(nb, np.float32), np.empty(nb, np.int32))
            tmax = np.full(nb, embree.MISS_T, np.float32)
            th, prim, u, v = (np.empty(nb, np.float32), np.empty(nb, np.int32), np.empty(nb, np.float32),
                              np.empty(nb, np.float32))
            sel, bounce, lvl = np.empty(nb, np.int64), np.empty((nb, 3), np.float32), np.empty((nb, 3), np.float32)
            P, N, NG, alb, emis = (np.empty((nb, 3), np.float32), np.empty((nb, 3), np.float32),
                                   np.empty((nb, 3), np.float32), np.empty((nb, 3), np.float32),
                                   np.empty((nb, 3), np.float32))
            rough, metal = np.empty(nb, np.float32), np.empty(nb, np.float32)
            # a bounce's points (the block's, then the last bounce's hits): their rows, keys, pixel
            # (block row) and the albedos of the path so far; two of each, this bounce's and the next's
            keys_a, keys_b = np.empty(nb, np.uint64), np.empty(nb, np.uint64)
            row_a, row_b = np.empty(nb, np.int64), np.empty(nb, np.int64)
            thr_a, thr_b = np.empty((nb, 3), np.float32), np.empty((nb, 3), np.float32)
            for r in range(rays):
                bounce[:] = 0.0
                LG, lg0, npts = G, b0, nb
                keys_a[:] = kb
                if bounces > 1:
                    for j in range(nb):
                        row_a[j] = j
                    thr_a[:] = 1.0
                # where a bounce's light goes: with one bounce straight into the pixels' (the points
                # are the block's), else per point, then times the path's albedos into its pixel's
                into = bounce if bounces == 1 else lvl
                for level in range(bounces):
                    dim = 4 + 6 * (bounces * r + level)
                    m = raygen.hemisphere_live(LG, lg0, keys_a[:npts], dim, eps, far, o, d, t, owner,
                                               embree.no_trace(trw), raygen.NOT_TRACED)
                    embree.trace_intersect(trw, o[:m], d[:m], tmax[:m], th, prim, u, v)
                    if bounces > 1:
                        lvl[:npts] = 0.0
                    k = gather.split_hits(prim, m, d, owner, into, env_kind, env_color, horizon, zenith, ground, sel)
                    hits = sel[:k]
                    _shade_hits(hits, prim, u, v, th, o, d, corners, face_normals, base_color, roughness, metallic,
                                emission, tex_offset, tex_w, tex_h, tex_data, P[:k], N[:k], NG[:k], alb[:k],
                                rough[:k], metal[:k], emis[:k])
                    gather.gather_keys(keys_a, owner, hits, k, keys_b)
                    hg = np.empty((9, k), np.float32)
                    raygen.surface_soa(P[:k], N[:k], NG[:k], hg)
                    hdirect = np.empty((k, 3), np.float32)
                    traced[w] += m + raygen.direct_block(hg, 0, keys_b[:k], ls, True, dim + 2, eps, far, lit,
                                                         hdirect)
                    gather.add_bounce(into, owner, hits, k, alb[:k], hdirect, None)
                    if bounces == 1:
                        break
                    for i in range(npts):  # this bounce's light, into its paths' pixels
                        for a in range(3):
                            bounce[row_a[i], a] += thr_a[i, a] * lvl[i, a]
                    if level + 1 < bounces:  # the hits start the next bounce
                        for i in range(k):
                            q = owner[hits[i]]
                            row_b[i] = row_a[q]
                            for a in range(3):
                                thr_b[i, a] = thr_a[q, a] * alb[i, a]
                        LG, lg0, npts = hg, 0, k
                        keys_a, keys_b = keys_b, keys_a
                        row_a, row_b = row_b, row_a
                        thr_a, thr_b = thr_b, thr_a
                for j in range(nb):
                    for a in range(3):
                        total[j, a] += bounce[j, a]
            inv = np.float32(rays)
            for j in range(nb):
                for a in range(3):
                    total[j, a] = total[j, a] / inv
            gather.write_lit(out, pix[b0:b1], emissive[b0:b1], albedo[b0:b1], direct, total, False)
            if indirect_image.shape[0] > 0:  # wanted (RtFrame.aux_image)
                for j in range(nb):
                    p = pix[b0 + j]
                    indirect_image[p, 0], indirect_image[p, 1], indirect_image[p, 2] = (total[j, 0], total[j, 1],
                                                                                        total[j, 2])
            gather.fill_uncovered(out, indirect_image, np.float32(0.0), pix, b0, b1, view_dir,
                                  (env_kind, env_color, horizon, zenith, ground))
    return traced.sum()


def trace(rf) -> dict:
    """The GI pass over the frame's G-buffer (one compiled call): radiance, and rt_indirect (the
    incoming indirect radiance, albedo x which is the outgoing) when asked."""
    out, indirect_image = rf.frame_outputs(name="rt_indirect")
    s, data = rf.gb.surface, rf.data
    rf.tracer.rays_traced += rf.tracer.run_parallel(
        gi_frame, rf.gb.soa, rf.key_base(4), rf.options.get("gi.rays_per_pixel"), rf.options.get("gi.bounces"),
        rf.options.get("gi.shadows"), data.lights.kernel_args, data.eps, data.far, rf.tracer.frame_target(),
        gather.env_args(rf.environment), data.mesh_args, rf.gb.index, s.emissive, s.albedo, rf.gb.view_dir, out,
        indirect_image)
    return rf.outputs(out, rt_indirect=indirect_image)
