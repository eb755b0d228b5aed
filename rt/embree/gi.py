"""Ray-traced global illumination: direct light at the primary hit (shadowed or not, the
study's two modes) plus `rays_per_pixel` bounce rays, each shaded at its hit with one light
sample and one sample of the environment (env_light.py), each with its shadow ray; `bounces`
> 1 continues the path. The bounce rays are cosine-weighted (the study's Lambert surfaces), or
with glTF's BRDF drawn from it, specular lobe included (bounce.py).

Light from emitters reaches bounce hits through their light samples (emissive triangles are
lights), so a bounce ray that happens to hit an emitter does not add its emission again; the
environment's light reaches the primary hit through the bounce rays that miss, and every
deeper hit through its own environment sample, so a ray that leaves a bounce's hit and misses
brings nothing."""
from __future__ import annotations

import numpy as np

from rt.embree import blocks, bounce, brdf, env_light, gather, light_sampling, raygen
from rt.embree import rtcore as embree
from rt.embree.jit import njit
from rt.embree.kernels import next_block, shade_hits
from rt.gi import GIPass

_shade_hits = shade_hits.serial  # inside a parallel kernel's blocks


@njit(cache=True, error_model="numpy", nogil=True)
def gi_frame(counter, bounds, scene, frame, base, rays, bounces, shadowed, ggx):
    """The whole GI pass in one call (scene, frame: kernel_args.SceneArgs, FrameArgs; base:
    RtFrame.key_base). One worker of the pass (Tracer.run_parallel runs one per thread), taking
    blocks of points (next_block on counter, bounds) until none is left; each block: direct
    light from one chosen light (shadowed, or unshadowed: the study's cheap mode), then `rays`
    paths of up to `bounces` bounces (_paths); then the block's pixels, its incoming indirect
    light into frame.aux, and the uncovered pixels around them; ggx: glTF's BRDF (brdf.py).
    Returns the rays it traced."""
    pix = frame.pix
    n = pix.shape[0]
    traced = 0
    lit = frame.target if shadowed else embree.no_trace(frame.target)  # no_trace: shadow rays not traced
    while True:
        b0, b1 = next_block(counter, bounds)
        if b0 >= n:
            break
        nb = b1 - b0
        keys = blocks.block_keys(pix, b0, b1, base)
        # dimensions 0-3: the light picked and its sample
        direct = brdf.accumulator(ggx, frame.view_dir, pix[b0:b1], frame.roughness[b0:b1])
        traced += light_sampling.direct_one(frame.points, b0, keys, scene.lights, 0, scene.far,
                                            lit, direct)
        indirect = np.zeros((nb, 3), np.float32)
        outgoing = np.zeros((nb, 3), np.float32)
        outgoing_spec = np.zeros((nb if ggx else 0, 3), np.float32)
        for r in range(rays):
            traced += _paths(scene, frame, lit, b0, keys, r, rays, bounces, ggx, indirect, outgoing, outgoing_spec)
        indirect /= np.float32(rays)
        outgoing /= np.float32(rays)
        outgoing_spec /= np.float32(rays)
        gather.write_gi(frame.out, frame.spec, pix[b0:b1], frame.emissive[b0:b1], frame.albedo[b0:b1],
                        frame.metallic[b0:b1], direct, indirect, outgoing, outgoing_spec, ggx)
        gather.put_rows(frame.aux, pix[b0:b1], indirect)
        gather.fill_uncovered(frame.out, frame.aux, np.float32(0.0), pix, b0, b1, frame.view_dir, frame.env)
    return traced


@njit(cache=True, error_model="numpy", nogil=True)
def _paths(scene, frame, lit, b0, keys, r, rays, bounces, ggx, indirect, outgoing, outgoing_spec):
    """Path r of every point of the block starting at b0 (keys: theirs): per bounce a
    cosine-weighted ray (ggx: one from the point's BRDF, bounce.py), its closest hit (the
    environment where it misses), the hit shaded and lit by its own light sample (lit: the
    shadow rays' target), and from the hit the next bounce's ray. Each bounce's light, times
    the albedos of the path's earlier hits, is added into indirect (one row per point: the
    incoming indirect light); with ggx, times the BRDF weights of the path's points, into
    outgoing (the indirect light leaving), and into indirect with the primary point's
    cosine-lobe weight in place of its BRDF's, and into outgoing_spec with the primary point's
    specular lobe's weight in place of its BRDF's (rt_specular). Random dimensions: 6 per bounce
    from 4 + 6 x (bounces x r), 3 a bounce for the hits' environment samples from 4 + 6 x bounces
    x rays + 3 x (bounces x r), and with ggx 1 a bounce for the lobe from 4 + 9 x bounces x rays
    + bounces x r. Returns the rays traced."""
    nb = keys.shape[0]
    env_kind, env_color, horizon, zenith, ground, texels = frame.env
    o, d, t, owner = (np.empty((nb, 3), np.float32), np.empty((nb, 3), np.float32), np.empty(nb, np.float32),
                      np.empty(nb, np.int32))
    tmax = np.full(nb, embree.MISS_T, np.float32)
    th, prim = np.empty(nb, np.float32), np.empty(nb, np.int32)  # hits: distance, triangle, barycentrics
    u, v = np.empty(nb, np.float32), np.empty(nb, np.float32)
    sel, level_light = np.empty(nb, np.int64), np.zeros((nb, 3), np.float32)
    P, N, NG, alb, emis = (np.empty((nb, 3), np.float32), np.empty((nb, 3), np.float32),
                           np.empty((nb, 3), np.float32), np.empty((nb, 3), np.float32), np.empty((nb, 3), np.float32))
    rough, metal = np.empty(nb, np.float32), np.empty(nb, np.float32)
    # a bounce's points (the block's, then the last bounce's hits): their rows, keys, pixel (block
    # row) and the albedos of the path so far (throughput); two of each, this bounce's and the next's
    G, g0, npts = frame.points, b0, nb
    keys_a, keys_b = keys.copy(), np.empty(nb, np.uint64)
    row_a, row_b = np.arange(nb), np.empty(nb, np.int64)
    thr_a, thr_b = np.ones((nb, 3), np.float32), np.empty((nb, 3), np.float32)
    # where a bounce's light goes: with one bounce straight into the block's rows, else per point,
    # then times the path's throughput into its row
    into = indirect if bounces == 1 and not ggx else level_light
    # with ggx: the points' view directions and materials, their rays' weights (bounce.brdf_live)
    # and the paths' weights so far for outgoing (thr_a), for indirect (thi_a) and outgoing_spec (ths_a)
    ng = nb if ggx else 0  # Lambert's paths need none of them
    V, W = np.empty((ng, 3), np.float32), np.empty((ng, 7), np.float32)
    thi_a, thi_b = np.ones((ng, 3), np.float32), np.empty((ng, 3), np.float32)
    ths_a, ths_b = np.ones((ng, 3), np.float32), np.empty((ng, 3), np.float32)
    m_alb, m_metal, m_rough = frame.albedo[b0:b0 + nb], frame.metallic[b0:b0 + nb], frame.roughness[b0:b0 + nb]
    if ggx:
        for i in range(nb):
            q = frame.pix[b0 + i]
            V[i, 0], V[i, 1], V[i, 2] = -frame.view_dir[q, 0], -frame.view_dir[q, 1], -frame.view_dir[q, 2]
    traced = 0
    for level in range(bounces):
        dim = 4 + 6 * (bounces * r + level)
        # ---- a ray from each point (cosine-weighted, or from its BRDF), and its closest hit ----
        if ggx:
            m = bounce.brdf_live(G, g0, keys_a[:npts], dim, 4 + 9 * bounces * rays + bounces * r + level,
                                 (V, m_alb, m_metal, m_rough), scene.far, (o, d, t, owner),
                                 embree.no_trace(frame.target), W)
        else:
            m = raygen.hemisphere_live(G, g0, keys_a[:npts], dim, scene.far, (o, d, t, owner),
                                       embree.no_trace(frame.target), raygen.NOT_TRACED)
        embree.trace_intersect(frame.target, o[:m], d[:m], tmax[:m], th, prim, u, v)
        level_light[:npts] = 0.0
        k = gather.split_hits(prim, m, d, owner, into, env_kind if level == 0 else 0, env_color, horizon, zenith,
                              ground, texels, sel)  # deeper, the environment was sampled at the hit left
        hits = sel[:k]
        # ---- the hits shaded, and lit by one light sample each ----
        _shade_hits(hits, (prim, u, v, th), (o, d), scene.mesh,
                    (P[:k], N[:k], NG[:k], alb[:k], rough[:k], metal[:k], emis[:k]))
        gather.gather_keys(keys_a, owner, hits, k, keys_b)
        hit_points = np.empty((9, k), np.float32)
        raygen.surface_soa(P[:k], N[:k], NG[:k], hit_points)
        hit_direct = brdf.accumulator(ggx, d, hits, rough[:k])
        traced += m + light_sampling.direct_one(hit_points, 0, keys_b[:k], scene.lights, dim + 2, scene.far,
                                                lit, hit_direct)
        env_dim = 4 + 6 * bounces * rays + 3 * (bounces * r + level)
        traced += env_light.env_shadow_rays(hit_points, 0, keys_b[:k], env_dim, frame.env, frame.env_dist,
                                            scene.far, lit, hit_direct, alb[:k], metal[:k])
        gather.add_bounce(into, owner, hits, k, alb[:k], metal[:k], hit_direct)
        if ggx:  # ---- this bounce's light, weighted, into its paths' rows ----
            _weigh(level_light, W, level, row_a, (thr_a, thi_a, ths_a), npts, (indirect, outgoing, outgoing_spec))
        if bounces == 1:
            break
        # ---- this bounce's light into its paths' rows; the hits start the next bounce ----
        if not ggx:
            for i in range(npts):
                for a in range(3):
                    indirect[row_a[i], a] += thr_a[i, a] * level_light[i, a]
        for i in range(k):
            q = owner[hits[i]]
            row_b[i] = row_a[q]
            for a in range(3):
                if ggx:
                    thr_b[i, a] = thr_a[q, a] * W[q, a]
                    thi_b[i, a] = thi_a[q, a] * (W[q, 3] if level == 0 else W[q, a])
                    ths_b[i, a] = ths_a[q, a] * (W[q, 4 + a] if level == 0 else W[q, a])
                else:
                    thr_b[i, a] = thr_a[q, a] * alb[i, a]
        if ggx:
            for i in range(k):
                j = hits[i]
                V[i, 0], V[i, 1], V[i, 2] = -d[j, 0], -d[j, 1], -d[j, 2]
            m_alb, m_metal, m_rough = alb[:k], metal[:k], rough[:k]
        G, g0, npts = hit_points, 0, k
        keys_a, keys_b = keys_b, keys_a
        row_a, row_b = row_b, row_a
        thr_a, thr_b = thr_b, thr_a
        thi_a, thi_b = thi_b, thi_a
        ths_a, ths_b = ths_b, ths_a
    return traced


@njit(cache=True, error_model="numpy", nogil=True)
def _weigh(level_light, W, level, row, paths, npts, sums):
    """With glTF's BRDF: the light that each point's ray brought (level_light), times its
    weights W (bounce.brdf_live) and its path's so far (paths: thr, thi, ths), into its path's row
    of the sums: outgoing (thr: the BRDF's weights), indirect (thi; the primary point's ray by its
    cosine-lobe weight W[:, 3]) and outgoing_spec (ths; the primary point's ray by its specular
    lobe's weights W[:, 4:7])."""
    thr, thi, ths = paths
    indirect, outgoing, outgoing_spec = sums
    for i in range(npts):
        p = row[i]
        for a in range(3):
            light = level_light[i, a]
            outgoing[p, a] += thr[i, a] * W[i, a] * light
            indirect[p, a] += thi[i, a] * (W[i, 3] if level == 0 else W[i, a]) * light
            outgoing_spec[p, a] += ths[i, a] * (W[i, 4 + a] if level == 0 else W[i, a]) * light


def trace(rf) -> dict:
    """The GI pass over the frame's G-buffer (one compiled call): radiance, and rt_indirect (the
    incoming indirect radiance, albedo x which is the outgoing) when asked."""
    out, indirect_image = rf.frame_outputs(name="rt_indirect")
    spec = rf.specular_image()
    p = GIPass.parameters(rf.options)
    rf.tracer.rays_traced += rf.tracer.run_parallel(
        gi_frame, len(rf.gb.index), rf.data.kernel_scene, rf.kernel_frame(out, indirect_image, spec),
        rf.key_base(GIPass.stream), p["rays"], p["bounces"], p["shadows"], rf.ggx)
    return rf.outputs(out, spec, rt_indirect=indirect_image)
