"""Reference path tracer: the ground truth for quality metrics.

Multi-bounce, with the scene's surface model (option brdf). The study's (trace_paths): diffuse
+ mirror-like specular consistent with the passes: surfaces smoother than
`reflections.roughness_threshold` reflect with Schlick's Fresnel probability and are diffuse
otherwise; at diffuse vertices next-event estimation (one light sample + shadow ray) and the
cosine-weighted bounce both reach emitting triangles, combined by multiple importance sampling
(the power heuristic: raygen.mis_weight, shading.emission_weight), so that a small bright
emitter seen close by does not make fireflies; emission counted in full at the camera and
after mirror bounces (where NEE cannot reach); the environment sampled by importance at the
same vertices (env_light, one more shadow ray), weighted against the bounces that escape to it
(_next_vertex). glTF's (trace_paths_ggx): GGX and Lambert lobes, below, emitters by NEE and
the bounces combined likewise against both lobes' density. Russian roulette after
`reference.rr_start` bounces."""
from __future__ import annotations

import numpy as np

from rt.embree import brdf
from rt.embree.kernels import uniforms
from rt.embree.shading import (
    INV_PI,
    LUMA,
    cosine_directions,
    direct_one,
    emission_weight,
    fresnel_schlick,
    mirror,
    trace_from,
)
from rt.environment import env_distribution
from rt.reference import ReferencePass


def trace_paths(cf, s, view, rng, max_bounces: int, rr_start: int, mis: bool = True) -> np.ndarray:
    """Every step runs even on no points, so each pixel draws the same numbers however it is chunked."""
    thr = cf.options.get("reflections.roughness_threshold")
    n = len(s)
    radiance = s.emissive.copy()
    beta = np.ones((n, 3), np.float32)
    alive = np.arange(n)
    d_in = view
    env = env_distribution(cf.environment) if mis else None  # the environment sampled by importance, with MIS
    for bounce in range(max_bounces + 1):
        f = np.where((s.roughness < thr)[:, None], fresnel_schlick(s, d_in), 0).astype(np.float32)
        p_spec = np.clip(f @ LUMA, 0, 1)
        u = rng.next(1)[:, 0]
        spec = u < p_spec
        diff = ~spec
        w_diff = np.where(diff[:, None], (1 - f) / np.maximum(1 - p_spec, 1e-6)[:, None], 0)
        # next-event estimation at diffuse vertices
        di = np.nonzero(diff)[0]
        sd, rd = s.take(di), rng.subset(di)
        e = direct_one(cf.data, cf.tracer, sd, rd, mis=mis)
        if env is not None:  # dimensions 5, 6 of the bounce
            ld, p_env, le, cs = env_light(cf, sd, rd, env)
            e += le * (cs * mis_weight(p_env, cs * INV_PI))[:, None]
        radiance[alive[di]] += beta[di] * w_diff[di] * s.albedo[di] * INV_PI * e
        if bounce == max_bounces:
            break
        d = cosine_directions(s, rng)
        si = np.nonzero(spec)[0]
        d[si] = mirror(d_in[si], s.take(si))
        beta = np.where(spec[:, None], beta * f / np.maximum(p_spec, 1e-6)[:, None], beta * w_diff * s.albedo)
        keep = np.einsum("ij,ij->i", d, s.ng) > 0  # diffuse directions below the true surface carry nothing
        escape = None  # the density of d for the environment's MIS: the cosine's, or -1 after a mirror
        if env is not None:
            escape = (env, np.where(spec, -1.0, np.maximum(np.einsum("ij,ij->i", d, s.n), 0) * INV_PI))
        alive, beta, d_in, s, rng = _next_vertex(cf, s, d, beta, keep, spec, radiance, alive, rng,
                                                 bounce + 1 >= rr_start, mis=mis, escape=escape)
    return radiance


def _next_vertex(cf, s, d, beta, keep, counts, radiance, alive, rng, roulette: bool, mis: bool = False,
                 escape=None, density=None):
    """A path step's end, shared by both surface models: Russian roulette (roulette: one number
    per point) among the paths kept, their rays along d traced; where they miss, the
    environment's light times beta goes to their pixels (alive), and where they hit, the hit's
    emission for paths whose `counts` is set, and with `mis` for the others (cosine-weighted
    bounces, or drawn with `density` where given: the GGX lobes') weighted against next-event
    estimation (shading.emission_weight). escape: where the
    environment is sampled too (env_light), (its distribution, each path's density of drawing d
    by its bounce, or -1 where the environment's light along d counts in full): the light of
    rays that miss weighted against the environment's sampling of d. Returns the paths that go
    on: (alive, beta, their directions, the surfaces hit, their generators)."""
    if roulette:
        q = np.clip(beta @ LUMA, 0.05, 0.95)
        keep &= rng.next(1)[:, 0] < q
        beta = beta / q[:, None]
    idx = np.nonzero(keep)[0]
    hit, sh, miss, hits = trace_from(cf.data, cf.tracer, s.take(idx), d[idx], with_hits=True)
    m = idx[miss]
    light = cf.environment.radiance(d[m])
    if escape is not None and len(m):
        env, q = escape
        w = mis_weight(q[m], env.pdf(d[m], cf.environment.rotation_u))
        light *= np.where(q[m] < 0, 1.0, w)[:, None]
    radiance[alive[m]] += beta[m] * light
    h = idx[hit]
    seen = counts[h]
    radiance[alive[h[seen]]] += beta[h[seen]] * sh.emissive[seen]
    if mis:
        other = np.flatnonzero(~seen & (sh.emissive.max(axis=1) > 0))  # emitters a diffuse bounce found
        if len(other):
            w = emission_weight(cf.data, s.take(h[other]), d[h[other]], hits.prim[hit[other]], hits.t[hit[other]],
                                None if density is None else density[h[other]])
            radiance[alive[h[other]]] += beta[h[other]] * sh.emissive[other] * w[:, None]
    return alive[h], beta[h], d[h], sh, rng.subset(h)


def trace_paths_ggx(cf, s, view, rng, max_bounces: int, rr_start: int, mis: bool = True) -> np.ndarray:
    """trace_paths for glTF's BRDF (rt/embree/brdf.py). At each vertex: next-event estimation
    with the whole BRDF, then the next direction from one lobe, picked with probability ~ its
    estimated weight: GGX's visible normals (weight F G1(l)) or cosine-weighted (weight
    c_diff (1 - F)). With `mis`, an emitter's light sample is weighted by the power heuristic
    against the lobes' drawing of its direction (the mixture's density, brdf.lobes_density) and
    the emission a bounce finds against the light's drawing of it, as trace_paths does for the
    cosine; point lights and suns, which bounces cannot find, keep their light samples whole
    (near-mirror surfaces' highlights included). Without it, emitters are next-event estimation's
    alone but for surfaces smoother than brdf.MIRROR_ROUGHNESS, whose specular lobe the bounce
    alone estimates (emission seen after it counting). The environment as in trace_paths, its
    sample weighted against each lobe's (mis; near-mirror lobes by the bounce alone). Random
    dimensions as trace_paths: lobe, light (4), environment (2, where sampled), direction (2),
    roulette."""
    radiance = s.emissive.copy()
    beta = np.ones((len(s), 3), np.float32)
    alive = np.arange(len(s))
    d_in = view
    env = env_distribution(cf.environment) if mis else None  # the environment sampled by importance, with MIS
    for bounce in range(max_bounces + 1):
        n, v = len(s), -d_in
        a = np.maximum(s.roughness * s.roughness, float(brdf.MIN_ALPHA))
        metal = s.metallic[:, None]
        f0 = 0.04 * (1 - metal) + s.albedo * metal
        c_diff = s.albedo * (1 - metal)
        f_nv = brdf.schlick(f0, np.einsum("ij,ij->i", s.n, v))
        w_spec, w_diff = f_nv @ LUMA, (c_diff * (1 - f_nv)) @ LUMA
        p_spec = np.where(w_spec + w_diff > 0, w_spec / np.maximum(w_spec + w_diff, 1e-12), 1.0)
        spec = rng.next(1)[:, 0] < p_spec
        near_mirror = s.roughness < brdf.MIRROR_ROUGHNESS
        # ---- next-event estimation: the light's sums (brdf.py), then the BRDF's lobes ----
        acc = np.zeros((n, brdf.P_SPEC + 1), np.float32)
        acc[:, brdf.VIEW:brdf.VIEW + 3] = v
        acc[:, brdf.ALPHA] = a
        acc[:, brdf.P_SPEC] = p_spec
        direct_one(cf.data, cf.tracer, s, rng, out=acc, mis=mis)
        e, ew = acc[:, 0:3], acc[:, 3:6]
        edv, edvw = acc[:, 6:9], acc[:, 9:12]
        light = c_diff * INV_PI * (1 - f0) * (e - ew)
        light += np.where((near_mirror & (not mis))[:, None], 0, f0 * edv + (1 - f0) * edvw)
        if env is not None:  # dimensions 5, 6 of the bounce: the environment's sample, both lobes
            ld, p_env, le, cs = env_light(cf, s, rng, env)
            diffuse, specular = brdf.ggx_lobes(s.n, v, ld, s.albedo, s.metallic, a)
            q_diff = (1 - p_spec) * cs * INV_PI
            q_spec = p_spec * brdf.visible_normal_pdf(s.n, v, ld, a)
            specular = np.where(near_mirror[:, None], 0, specular * mis_weight(p_env, q_spec)[:, None])
            light += (diffuse * mis_weight(p_env, q_diff)[:, None] + specular) * le * cs[:, None]
        radiance[alive] += beta * light
        if bounce == max_bounces:
            break
        # ---- the next direction from the lobe picked, the throughput, the roulette ----
        dim = rng.dim
        cosine = cosine_directions(s, rng)  # from dimensions dim, dim + 1; the GGX lobe's from the same
        u, m = np.empty((n, 2), np.float32), np.empty((n, 3), np.float32)
        if n:
            uniforms(rng.key, dim, 2, u)
            brdf.visible_normals(s.n, np.ascontiguousarray(v, np.float32), a.astype(np.float32), u, m)
        vm = np.einsum("ij,ij->i", v, m)
        mirrored = (2 * vm[:, None] * m - v).astype(np.float32)
        d = np.where(spec[:, None], mirrored, cosine).astype(np.float32)
        h = brdf.unit(v + d)
        f_vh = brdf.schlick(f0, np.einsum("ij,ij->i", v, h))
        g1_l = brdf.smith_g1(np.einsum("ij,ij->i", s.n, d), a)
        weight_spec = brdf.schlick(f0, vm) * g1_l[:, None] / np.maximum(p_spec, 1e-6)[:, None]
        weight_diff = c_diff * (1 - f_vh) / np.maximum(1 - p_spec, 1e-6)[:, None]
        beta = (beta * np.where(spec[:, None], weight_spec, weight_diff)).astype(np.float32)
        keep = (np.einsum("ij,ij->i", d, s.ng) > 0) & (np.einsum("ij,ij->i", d, s.n) > 0)
        mirrored_lobe = spec & near_mirror
        # emission at the next hit: in full after the near-mirror lobe without mis, else weighted
        counts = mirrored_lobe & (not mis)
        escape = density = None
        if env is not None or mis:  # the densities with which each lobe draws d
            q_spec = p_spec * brdf.visible_normal_pdf(s.n, v, d, a)
            q_diff = (1 - p_spec) * np.maximum(np.einsum("ij,ij->i", d, s.n), 0) * INV_PI
        if env is not None:  # the lobe picked's, against the environment's drawing of d
            escape = (env, np.where(mirrored_lobe, -1.0, np.where(spec, q_spec, q_diff)))
        if mis:  # both lobes', against the light's drawing of it
            density = q_spec + q_diff
        alive, beta, d_in, s, rng = _next_vertex(cf, s, d, beta, keep, counts, radiance, alive, rng,
                                                 bounce + 1 >= rr_start, mis=mis, escape=escape, density=density)
    return radiance


def mis_weight(p_this: np.ndarray, p_other: np.ndarray) -> np.ndarray:
    """The power heuristic's weight of a sample drawn with density p_this against a strategy
    that draws it with p_other (raygen.mis_weight for whole arrays)."""
    a, b = np.square(p_this, dtype=np.float64), np.square(p_other, dtype=np.float64)
    return np.where(a + b > 0, a / np.where(a + b > 0, a + b, 1), 0).astype(np.float32)


def env_light(cf, s, rng, env):
    """One sample of the environment's light at points s, drawn by importance (env: its
    rt/environment.py EnvDistribution; two dimensions of rng) with a shadow ray: (directions,
    their densities, radiance / density where the direction is above the shading and the true
    surface and nothing blocks it, else 0, and the cosine with the shading normal)."""
    u = rng.next(2)
    d, p_env = env.sample(u[:, 0], u[:, 1], cf.environment.rotation_u)
    cs = np.einsum("ij,ij->i", d, s.n).astype(np.float32)
    up = np.flatnonzero((cs > 0) & (np.einsum("ij,ij->i", d, s.ng) > 0) & (p_env > 0))
    le = np.zeros((len(s), 3), np.float32)
    if len(up):
        su = s.take(up)
        seen = ~cf.tracer.occluded(cf.data.offset(su), d[up], cf.data.far)
        le[up] = cf.environment.radiance(d[up]) * (seen / p_env[up])[:, None]
    return d, p_env, le, np.maximum(cs, 0)


def trace(rf) -> dict:
    out = rf.background()
    p = ReferencePass.parameters(rf.options)
    bounces, rr, mis = p["max_bounces"], p["rr_start"], bool(p["mis"])
    if rf.ggx:
        def paths(cf):
            return trace_paths_ggx(cf, cf.s, cf.view, cf.rng(5), bounces, rr, mis)
    else:
        def paths(cf):
            return trace_paths(cf, cf.s, cf.view, cf.rng(5), bounces, rr, mis)
    rf.for_chunks(lambda cf: cf.put(out, paths(cf)), streams=(ReferencePass.stream,))
    return {"radiance": out}
