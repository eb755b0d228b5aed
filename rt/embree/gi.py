"""Ray-traced global illumination: direct light at the primary hit (shadowed or not, the
study's two modes) plus `rays_per_pixel` cosine-weighted bounce rays, each shaded at its hit
with one light sample and a shadow ray; `bounces` > 1 continues the path.

Light from emitters reaches bounce hits through their light samples (emissive triangles are
lights), so a bounce ray that happens to hit an emitter does not add its emission again."""
from __future__ import annotations

import numpy as np
from numba import njit, prange

from rt.embree import gather, raygen, scratch
from rt.embree import rtcore as embree
from rt.embree.kernels import shade_hits
from rt.embree.shading import direct_one, empty_surface

_shade_hits = shade_hits.serial  # inside a parallel kernel's blocks




def incoming_indirect(cf, s, rng, bounces: int, shadowed: bool, depth: int = 0, G=None) -> np.ndarray:
    """One-sample estimate of the radiance arriving along a cosine-sampled direction, per point
    of s (a scratch buffer of this depth: valid until this thread's next call at this depth).
    Every step runs even when no ray hits, so each pixel draws the same numbers however the
    frame is chunked. G: s.soa() if at hand."""
    n, name = len(s), f"gi{depth}"
    out = scratch.buffer(name + ".out", (n, 3))
    out.fill(0)
    o, d, _, owner = scratch.rays(name, n)
    G = s.soa(name + ".soa") if G is None else G
    m = raygen.hemisphere_live(*G, rng.key, rng.reserve(2), cf.data.eps, cf.data.far, o, d, _, owner, 0,
                               raygen.NOT_TRACED)
    hits = cf.tracer.intersect(o[:m], d[:m])  # rays below the true surface carry nothing
    sel = scratch.buffer(name + ".sel", (m,), np.int64)
    k = gather.split_hits(hits.prim, m, d, owner, out, *gather.env_args(cf.environment), sel)
    sel = sel[:k]
    sh = cf.data.surface(hits, d, o, sel=sel, out=empty_surface(k, name + ".hit"))
    keys = scratch.buffer(name + ".keys", (k,), np.uint64)
    gather.gather_keys(rng.key, owner, sel, k, keys)
    hrng = rng.with_keys(keys)
    hg = sh.soa(name + ".hit.soa")
    direct = direct_one(cf.data, cf.tracer, sh, hrng, shadowed, out=scratch.buffer(name + ".direct", (k, 3)), G=hg)
    inner = incoming_indirect(cf, sh, hrng, bounces - 1, shadowed, depth + 1, hg) if bounces > 1 else None
    gather.add_bounce(out, owner, sel, k, sh.albedo, direct, inner)
    return out


def indirect_light(cf, s, rng, G=None) -> np.ndarray:
    """Mean incoming indirect radiance over gi.rays_per_pixel rays (albedo x this = outgoing)."""
    rays = cf.options.get("gi.rays_per_pixel")
    shadowed = cf.options.get("gi.shadows")
    bounces = cf.options.get("gi.bounces")
    total = np.zeros((len(s), 3), np.float32)
    for _ in range(rays):
        total += incoming_indirect(cf, s, rng, bounces, shadowed, G=G)
    return total / np.float32(rays)


@njit(cache=True, error_model="numpy", nogil=True, parallel=True)
def gi_frame(workers, G, base, rays, bounces, shadowed, lights, eps, far, scene, env, mesh, pix, emissive, albedo,
             view_dir, out, indirect_image):
    """The whole GI pass (shadowed or not) in one call: blocks of points split among workers
    (raygen.next_block), each doing what a chunk does (the same numbers, in the same order):
    direct light from one chosen light, then per bounce ray a cosine ray, its closest hit, the
    hit's shading and its own light sample, and from the hit the next bounce's ray, up to
    `bounces`; then the pixels written, with the uncovered ones around them
    (gather.fill_uncovered). Returns the rays traced. env: gather.env_args; mesh: what
    SceneData.surface shades hits with.

    A path's light is added as it goes, times the albedos of its earlier hits (thr), where the
    chunked path nests each bounce's light inside the one before (incoming_indirect): the same
    sum, up to float rounding, and the very same numbers for one bounce."""
    n = pix.shape[0]
    # the loop body may not take tuples of arrays from outside (numba): unpacked here, rebuilt there
    kind, lpos, ldir, lrad, cos_out, spot_scale, cos_ang, lum = lights[0]
    start, rows, keep, alias = lights[1]
    lx, ly, lz, sx, sy, sz, glum, gcos, gscale, sun, cx, cy, cz, radius, power = lights[2]
    n_lights = lights[3]
    env_kind, env_color, horizon, zenith, ground = env
    corners, face_normals, base_color, roughness, metallic, emission, tex_offset, tex_w, tex_h, tex_data = mesh
    lit_scene = scene if shadowed else 0  # 0: direct light unshadowed (raygen.direct_block)
    bounds = raygen.block_bounds(n, workers)
    counter = np.zeros(1, np.int64)  # blocks taken (raygen.next_block)
    traced = np.zeros(workers, np.int64)  # by each worker (a scalar summed across this prange came out 0)
    for w in prange(workers):  # each takes blocks until none is left
        ls = ((kind, lpos, ldir, lrad, cos_out, spot_scale, cos_ang, lum), (start, rows, keep, alias),
              (lx, ly, lz, sx, sy, sz, glum, gcos, gscale, sun, cx, cy, cz, radius, power), n_lights)
        while True:
            b0, b1 = raygen.next_block(counter, bounds)
            if b0 >= n:
                break
            nb = b1 - b0
            kb = raygen.block_keys(pix, b0, b1, base)
            direct = np.empty((nb, 3), np.float32)
            traced[w] += raygen.direct_block(G, b0, kb, ls, True, 0, eps, far, lit_scene, direct)
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
                    m = raygen.hemisphere_live(LG, lg0, keys_a[:npts], dim, eps, far, o, d, t, owner, 0,
                                               np.zeros((0, 3), np.float32))
                    embree.intersect(scene, o[:m], d[:m], tmax[:m], th, prim, u, v)
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
                    traced[w] += m + raygen.direct_block(hg, 0, keys_b[:k], ls, True, dim + 2, eps, far, lit_scene,
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
    shadowed = rf.options.get("gi.shadows")
    scene = rf.tracer.frame_scene()
    if scene and rf.gb.soa is not None:
        out, indirect_image = rf.frame_outputs(name="rt_indirect")
        s, data = rf.gb.surface, rf.data  # one compiled call: no Python per chunk
        rf.tracer.rays_traced += rf.tracer.run_parallel(
            gi_frame, rf.gb.soa, rf.key_base(4), rf.options.get("gi.rays_per_pixel"), rf.options.get("gi.bounces"),
            shadowed,
            data.lights.kernel_args, data.eps, data.far, scene, gather.env_args(rf.environment), data.mesh_args,
            rf.gb.index, s.emissive, s.albedo, rf.gb.view_dir, out, indirect_image)
        return rf.outputs(out, rt_indirect=indirect_image)

    out, indirect_image = rf.background(), rf.aux_image(name="rt_indirect")

    def work(cf):
        s, rng = cf.s, cf.rng(4)
        G = cf.soa
        direct = direct_one(cf.data, cf.tracer, s, rng, shadowed, out=scratch.buffer("gi.direct", (len(s), 3)), G=G)
        indirect = indirect_light(cf, s, rng, G)
        gather.write_lit(out, cf.idx, s.emissive, s.albedo, direct, indirect, False)
        cf.put(indirect_image, indirect)

    rf.for_chunks(work, streams=(4,))
    return rf.outputs(out, rt_indirect=indirect_image)
