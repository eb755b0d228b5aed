"""Ray-traced reflections: where the G-buffer's roughness is below the threshold, trace the
mirror direction and shade the hit; Schlick's Fresnel blends the reflection with the local
colour. Lit colours (points and hits) take one light sample and one of the environment, the
latter on the diffuse lobe alone where a mirror or glossy ray brings the specular one.
`lit=false` reproduces the study (hits show their material colour only)."""
from __future__ import annotations

import numpy as np

from rt.embree import blocks, brdf, env_light, gather, light_sampling, raygen
from rt.embree import rtcore as embree
from rt.embree.jit import njit
from rt.embree.kernels import next_block, shade_hits
from rt.reflections import ReflectionsPass

_shade_hits = shade_hits.serial  # inside a parallel kernel's blocks


@njit(cache=True, error_model="numpy", nogil=True)
def _mirror_hits(scene, frame, points, V, sel, keys, dim0, lit, ggx, below, refl):
    """One mirror bounce: from the points sel[k] of points (P, N, NG) seen along V[k] (keys[k]: their
    generators), ray k's closest hit shaded (lit: with its own light sample, dimensions
    dim0..dim0+3, and the environment's, _env_sample; ggx: glTF's BRDF, brdf.py) and its colour;
    hits smoother than `below` reflect further; refl[k] gains the environment where ray k missed.
    Returns the rays that hit (hits), every ray's direction (d), the hits' shading
    (P, N, NG, albedo, roughness, metallic, emission: Surface.arrays' order), colour and keys,
    and the rays traced."""
    P, N, NG = points
    m = sel.shape[0]
    o, d = np.empty((m, 3), np.float32), np.empty((m, 3), np.float32)
    gather.mirror_rays(P, N, NG, V, sel, o, d)
    return _hits_of(scene, frame, o, d, keys, dim0, lit, ggx, below, refl)


@njit(cache=True, error_model="numpy", nogil=True)
def _env_sample(scene, frame, G, g0, keys, dim0, acc, albedo, metallic, diffuse):
    """The environment's light at the points of G (surface_soa rows from column g0; keys, acc,
    albedo, metallic: theirs, from row 0) with its shadow ray (env_light.env_rays): on the
    diffuse lobe alone where diffuse[i] (a mirror or glossy ray brings the specular one); its
    numbers from brdf.REFLECTION_ENV_DIM + 3 (dim0 / 4), dim0 being the points' light
    dimensions. Returns the rays traced."""
    return env_light.env_rays(G, g0, keys, brdf.REFLECTION_ENV_DIM + 3 * (dim0 // 4), frame.env, frame.env_dist,
                              scene.far, frame.target, acc, albedo, metallic, diffuse)


@njit(cache=True, error_model="numpy", nogil=True)
def _hits_of(scene, frame, o, d, keys, dim0, lit, ggx, below, refl):
    """_mirror_hits for rays (o, d) already made (keys[k]: ray k's generator)."""
    env_kind, env_color, horizon, zenith, ground, texels = frame.env
    m = o.shape[0]
    th, prim = np.empty(m, np.float32), np.empty(m, np.int32)  # hits: distance, triangle, barycentrics
    u, v = np.empty(m, np.float32), np.empty(m, np.float32)
    embree.trace_intersect(frame.target, o, d, np.full(m, embree.MISS_T, np.float32), th, prim, u, v)
    owner, hit = np.arange(m), np.empty(m, np.int64)
    k = gather.split_hits(prim, m, d, owner, refl, env_kind, env_color, horizon, zenith, ground, texels, hit)
    hits = hit[:k]
    HP, HN, HNG, halb, hemis = (np.empty((k, 3), np.float32), np.empty((k, 3), np.float32),
                                np.empty((k, 3), np.float32), np.empty((k, 3), np.float32),
                                np.empty((k, 3), np.float32))
    hrough, hmetal = np.empty(k, np.float32), np.empty(k, np.float32)
    _shade_hits(hits, (prim, u, v, th), (o, d), scene.mesh, (HP, HN, HNG, halb, hrough, hmetal, hemis))
    hkeys = np.empty(k, np.uint64)
    gather.gather_keys(keys, owner, hits, k, hkeys)
    hdirect = brdf.accumulator(ggx and lit, d, hits, hrough)
    traced = m
    if lit:
        hg = np.empty((9, k), np.float32)
        raygen.surface_soa(HP, HN, HNG, hg)
        traced += light_sampling.direct_one(hg, 0, hkeys, scene.lights, dim0, scene.far, frame.target,
                                            hdirect)
        traced += _env_sample(scene, frame, hg, 0, hkeys, dim0, hdirect, halb, hmetal, hrough < below)
    colour = np.zeros((k, 3), np.float32)
    gather.add_hit_colour(colour, np.arange(k), k, hemis, halb, hmetal, hdirect, lit)
    return hits, d, (HP, HN, HNG, halb, hrough, hmetal, hemis), colour, hkeys, traced


@njit(cache=True, error_model="numpy", nogil=True)
def _deeper(scene, frame, depth, thr, lit, ggx, surf, d, hits, keys, colour):
    """Mirrors 2..depth below the first mirror's hits (surf: their shading, as _mirror_hits
    returns it; their keys and colour; d: the
    first mirror rays' directions): each level's smooth hits reflect again (_mirror_hits, light
    dimensions 4 x level), then, deepest first, each level's colour takes Fresnel's blend with
    the reflections below it; colour gains the second
    mirror's. Returns the rays traced."""
    HP, HN, HNG, halb, hrough, hmetal, hemis = surf
    levels = depth - 1
    cap = hits.shape[0]  # no level has more points than the first has hits
    sel, hit_l = np.empty((levels, cap), np.int64), np.empty((levels, cap), np.int64)
    count, hit_count = np.zeros(levels, np.int64), np.zeros(levels, np.int64)
    V, refl = np.empty((levels, cap, 3), np.float32), np.zeros((levels, cap, 3), np.float32)
    col, emis, alb, nrm = (np.empty((levels, cap, 3), np.float32), np.empty((levels, cap, 3), np.float32),
                           np.empty((levels, cap, 3), np.float32), np.empty((levels, cap, 3), np.float32))
    metal = np.empty((levels, cap), np.float32)
    traced = 0
    pP, pN, pNG, prough, pd, phits, pkeys = HP, HN, HNG, hrough, d, hits, keys  # the level above
    for lv in range(levels):
        m = 0
        for i in range(phits.shape[0]):  # the smooth hits of the level above, seen along its rays
            if prough[i] < thr:
                q = phits[i]
                sel[lv, m] = i
                V[lv, m, 0], V[lv, m, 1], V[lv, m, 2] = pd[q, 0], pd[q, 1], pd[q, 2]
                m += 1
        count[lv] = m
        skeys = np.empty(m, np.uint64)
        for j in range(m):
            skeys[j] = pkeys[sel[lv, j]]
        below = thr if lv + 2 < depth else np.float32(0.0)  # whether this level's hits reflect again
        h, dd, surf2, col2, keys2, t = _mirror_hits(scene, frame, (pP, pN, pNG), V[lv, :m], sel[lv, :m], skeys,
                                                   4 * (lv + 2), lit, ggx, below, refl[lv])
        P2, N2, NG2, alb2, rough2, metal2, emis2 = surf2
        traced += t
        k = h.shape[0]
        hit_count[lv] = k
        for i in range(k):  # loops, not arrays assigned to slices: their shape checks compile for seconds
            hit_l[lv, i], metal[lv, i] = h[i], metal2[i]
            for a in range(3):
                col[lv, i, a], emis[lv, i, a] = col2[i, a], emis2[i, a]
                alb[lv, i, a], nrm[lv, i, a] = alb2[i, a], N2[i, a]
        pP, pN, pNG, prough, pd, phits, pkeys = P2, N2, NG2, rough2, dd, h, keys2
    for lv in range(levels - 1, -1, -1):  # deepest first: blend with the level below, then into refl
        if lv + 1 < levels:
            c = count[lv + 1]
            gather.blend_mirror(col[lv], sel[lv + 1, :c], emis[lv], alb[lv], metal[lv], nrm[lv], V[lv + 1, :c],
                                refl[lv + 1], None, ggx and lit)
        for i in range(hit_count[lv]):
            for a in range(3):
                refl[lv, hit_l[lv, i], a] = col[lv, i, a]
    c = count[0]
    gather.blend_mirror(colour, sel[0, :c], hemis, halb, hmetal, HN, V[0, :c], refl[0], None, ggx and lit)
    return traced


@njit(cache=True, error_model="numpy", nogil=True)
def _glossy(scene, frame, pix, b0, nb, keys, thr, local, local_spec):
    """GGX's glossy reflection at the block's points at or above thr (brdf=ggx, lit colours):
    one ray per point from its lobe (visible normals, dimensions brdf.GLOSSY_DIM + 0, 1), its
    hit's lit colour (light dimensions 4..7) or the environment, added to local[j] with the
    sample's weight F(v.m) G1(l) (rt/embree/brdf.py), and to local_spec (the specular part).
    Returns the rays traced."""
    rows = np.empty(nb, np.int64)
    m = 0
    for j in range(nb):
        if not frame.roughness[b0 + j] < thr:
            rows[m] = j
            m += 1
    o, d = np.empty((m, 3), np.float32), np.empty((m, 3), np.float32)
    weight, gkeys = np.zeros((m, 3), np.float32), np.empty(m, np.uint64)
    for k in range(m):
        j = rows[k]
        i, p = b0 + j, pix[b0 + j]
        gkeys[k] = keys[j]
        gather.glossy_ray(frame.p[i], frame.n[i], frame.ng[i], frame.view_dir[p], frame.albedo[i],
                          frame.metallic[i], frame.roughness[i], keys[j], o[k], d[k], weight[k])
    refl = np.zeros((m, 3), np.float32)
    hits, _, _, colour, _, traced = _hits_of(scene, frame, o, d, gkeys, 4, True, True, np.float32(0.0), refl)
    for i in range(hits.shape[0]):
        for a in range(3):
            refl[hits[i], a] = colour[i, a]
    for k in range(m):
        for a in range(3):
            local[rows[k], a] += weight[k, a] * refl[k, a]
            local_spec[rows[k], a] += weight[k, a] * refl[k, a]
    return traced


@njit(cache=True, error_model="numpy", nogil=True)
def reflections_frame(counter, bounds, scene, frame, base, thr, lit, depth, ggx, glossy):
    """The whole reflections pass in one call (scene, frame: kernel_args.SceneArgs, FrameArgs;
    base: RtFrame.key_base). One worker of the pass (Tracer.run_parallel runs one per thread),
    taking blocks of points (next_block on counter, bounds) until none is left; each block: the
    local colour (_local), a mirror ray from each point smoother than thr, its closest hit shaded
    (lit: with its own light sample), up to `depth` mirrors deep (_deeper), Fresnel's blend
    (_blend; with glossy, points at or above thr add one ray of their GGX lobe, _glossy); then
    the block's pixels, the reflection (RGBA) into frame.aux, and the uncovered pixels around
    them (_write). Returns the rays it traced."""
    pix = frame.pix
    traced = 0
    while True:
        b0, b1 = next_block(counter, bounds)
        if b0 >= pix.shape[0]:
            return traced
        keys = blocks.block_keys(pix, b0, b1, base)
        local, local_spec = np.empty((b1 - b0, 3), np.float32), np.zeros((b1 - b0, 3), np.float32)
        traced += _local(scene, frame, b0, b1, keys, lit, ggx, thr, glossy and ggx, local, local_spec)
        smooth, near, V, skeys = _smooth_points(frame, b0, b1, keys, thr)
        refl = np.zeros((near.shape[0], 3), np.float32)
        hits, d, surf, colour, hkeys, t = _mirror_hits(scene, frame, (frame.p, frame.n, frame.ng), V, smooth, skeys,
                                                       4, lit, ggx, thr if depth > 1 else np.float32(0.0), refl)
        traced += t
        if depth > 1:
            traced += _deeper(scene, frame, depth, thr, lit, ggx, surf, d, hits, hkeys, colour)
        reflection = _blend(frame, b0, b1, (local, local_spec), near, V, refl, hits, colour, lit, ggx)
        if glossy and ggx and lit:
            traced += _glossy(scene, frame, pix, b0, b1 - b0, keys, thr, local, local_spec)
        _write(frame, b0, b1, local, local_spec, reflection)


@njit(cache=True, error_model="numpy", nogil=True)
def reflections_one(counter, bounds, scene, frame, base, thr, lit, ggx):
    """reflections_frame with one mirror and no glossy lobe (the defaults), a kernel of its own
    so that it compiles without _deeper and _glossy (issue 44)."""
    pix = frame.pix
    traced = 0
    while True:
        b0, b1 = next_block(counter, bounds)
        if b0 >= pix.shape[0]:
            return traced
        keys = blocks.block_keys(pix, b0, b1, base)
        local, local_spec = np.empty((b1 - b0, 3), np.float32), np.zeros((b1 - b0, 3), np.float32)
        traced += _local(scene, frame, b0, b1, keys, lit, ggx, thr, False, local, local_spec)
        smooth, near, V, skeys = _smooth_points(frame, b0, b1, keys, thr)
        refl = np.zeros((near.shape[0], 3), np.float32)
        hits, _, _, colour, _, t = _mirror_hits(scene, frame, (frame.p, frame.n, frame.ng), V, smooth, skeys, 4, lit,
                                                ggx, np.float32(0.0), refl)
        traced += t
        reflection = _blend(frame, b0, b1, (local, local_spec), near, V, refl, hits, colour, lit, ggx)
        _write(frame, b0, b1, local, local_spec, reflection)


@njit(cache=True, error_model="numpy", nogil=True)
def _local(scene, frame, b0, b1, keys, lit, ggx, thr, glossy, local, local_spec):
    """The local colour of points b0..b1 into local (lit: one chosen light, shadowed, and the
    environment's sample, on the diffuse lobe alone where a mirror ray (smoother than thr) or a
    glossy ray brings the specular one; else the albedo, as the study), and with ggx its
    specular part into local_spec (brdf.specular_out); returns the rays traced."""
    albedo = frame.albedo[b0:b1]
    if not lit:
        for j in range(b1 - b0):  # a loop: an array assigned to a slice compiles its shape check for seconds
            for a in range(3):
                local[j, a] = albedo[j, a]
        return 0
    acc = brdf.accumulator(ggx, frame.view_dir, frame.pix[b0:b1], frame.roughness[b0:b1])
    traced = light_sampling.direct_one(frame.points, b0, keys, scene.lights, 0, scene.far, frame.target, acc)
    if frame.env[0] != 0:
        diffuse = frame.roughness[b0:b1] < thr
        if glossy:
            diffuse[:] = True
        traced += _env_sample(scene, frame, frame.points, b0, keys, 0, acc, albedo, frame.metallic[b0:b1], diffuse)
    for j in range(b1 - b0):
        for a in range(3):
            local[j, a] = brdf.light_out(acc, j, a, albedo[j, a], frame.metallic[b0 + j])
            if ggx:
                local_spec[j, a] = brdf.specular_out(acc, j, a, albedo[j, a], frame.metallic[b0 + j])
    return traced


@njit(cache=True, error_model="numpy", nogil=True)
def _smooth_points(frame, b0, b1, keys, thr):
    """The points of b0..b1 smoother than thr, which trace a mirror ray: their frame rows, block
    rows, view directions and keys."""
    nb = b1 - b0
    smooth, near = np.empty(nb, np.int64), np.empty(nb, np.int64)
    m = 0
    for j in range(nb):
        if frame.roughness[b0 + j] < thr:
            smooth[m], near[m] = b0 + j, j
            m += 1
    V, skeys = np.empty((m, 3), np.float32), np.empty(m, np.uint64)
    for k in range(m):
        p = frame.pix[smooth[k]]
        V[k, 0], V[k, 1], V[k, 2] = frame.view_dir[p, 0], frame.view_dir[p, 1], frame.view_dir[p, 2]
        skeys[k] = keys[near[k]]
    return smooth[:m], near[:m], V, skeys


@njit(cache=True, error_model="numpy", nogil=True)
def _blend(frame, b0, b1, colours, near, V, refl, hits, colour, lit, ggx):
    """Fresnel's blend of the mirrors' colours (refl: the environment where a ray missed, the hits'
    colours put in here) into local (colours: local and its specular part; ggx and lit: glTF's
    BRDF, brdf.py, whose direct light has its own Fresnel split: the reflection is added, F x it,
    to both); returns the reflection (RGBA)."""
    local, local_spec = colours
    for i in range(hits.shape[0]):
        for a in range(3):
            refl[hits[i], a] = colour[i, a]
    nb = b1 - b0
    reflection = np.zeros((nb, 4), np.float32)
    gather.blend_mirror(local, near, np.zeros((nb, 3), np.float32), frame.albedo[b0:b1], frame.metallic[b0:b1],
                        frame.n[b0:b1], V, refl, reflection, ggx and lit, local_spec)
    return reflection


@njit(cache=True, error_model="numpy", nogil=True)
def _write(frame, b0, b1, local, local_spec, reflection):
    """The block's pixels (local colour plus emission), its specular part into frame.spec (where
    asked), its reflection into frame.aux, and the uncovered pixels around it."""
    pix = frame.pix
    local += frame.emissive[b0:b1]
    gather.put_rows(frame.out, pix[b0:b1], local)
    gather.put_rows(frame.spec, pix[b0:b1], local_spec)
    gather.put_rows(frame.aux, pix[b0:b1], reflection)
    gather.fill_uncovered(frame.out, frame.aux, np.float32(0.0), pix, b0, b1, frame.view_dir, frame.env)


def trace(rf) -> dict:
    """The reflections pass over the frame's G-buffer (one compiled call): radiance, and
    rt_reflection (RGBA, alpha 1 where a mirror ray was traced) when asked."""
    out, reflection_image = rf.frame_outputs(4, name="rt_reflection")
    spec = rf.specular_image()
    p = ReflectionsPass.parameters(rf.options)
    args = (rf.data.kernel_scene, rf.kernel_frame(out, reflection_image, spec), rf.key_base(ReflectionsPass.stream),
            np.float32(p["threshold"]), p["lit"])
    if p["depth"] > 1 or p["glossy"]:
        kernel, args = reflections_frame, (*args, p["depth"], rf.ggx, p["glossy"])
    else:
        kernel, args = reflections_one, (*args, rf.ggx)
    rf.tracer.rays_traced += rf.tracer.run_parallel(kernel, len(rf.gb.index), *args)
    return rf.outputs(out, spec, rt_reflection=reflection_image)
