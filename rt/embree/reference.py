"""Reference path tracer: the ground truth for quality metrics.

Multi-bounce, diffuse + mirror-like specular consistent with the passes: surfaces smoother
than `reflections.roughness_threshold` reflect with Schlick's Fresnel probability and are
diffuse otherwise; next-event estimation (one light sample + shadow ray) at diffuse vertices;
emission counted at the camera and after mirror bounces (where NEE cannot reach); Russian
roulette after `reference.rr_start` bounces."""
from __future__ import annotations

import numpy as np

from rt.embree.shading import INV_PI, LUMA, cosine_directions, direct_one, fresnel_schlick, mirror, trace_from


def trace_paths(cf, s, view, rng, max_bounces: int, rr_start: int) -> np.ndarray:
    """Every step runs even on no points, so each pixel draws the same numbers however it is chunked."""
    thr = cf.options.get("reflections.roughness_threshold")
    n = len(s)
    radiance = s.emissive.copy()
    beta = np.ones((n, 3), np.float32)
    alive = np.arange(n)
    d_in = view
    for bounce in range(max_bounces + 1):
        f = np.where((s.roughness < thr)[:, None], fresnel_schlick(s, d_in), 0).astype(np.float32)
        p_spec = np.clip(f @ LUMA, 0, 1)
        u = rng.next(1)[:, 0]
        spec = u < p_spec
        diff = ~spec
        w_diff = np.where(diff[:, None], (1 - f) / np.maximum(1 - p_spec, 1e-6)[:, None], 0)
        # next-event estimation at diffuse vertices
        di = np.nonzero(diff)[0]
        e = direct_one(cf.data, cf.tracer, s.take(di), rng.subset(di))
        radiance[alive[di]] += beta[di] * w_diff[di] * s.albedo[di] * INV_PI * e
        if bounce == max_bounces:
            break
        d = cosine_directions(s, rng)
        si = np.nonzero(spec)[0]
        d[si] = mirror(d_in[si], s.take(si))
        beta = np.where(spec[:, None], beta * f / np.maximum(p_spec, 1e-6)[:, None], beta * w_diff * s.albedo)
        keep = np.einsum("ij,ij->i", d, s.ng) > 0  # diffuse directions below the true surface carry nothing
        if bounce + 1 >= rr_start:
            q = np.clip(beta @ LUMA, 0.05, 0.95)
            keep &= rng.next(1)[:, 0] < q
            beta = beta / q[:, None]
        idx = np.nonzero(keep)[0]
        hit, sh, miss = trace_from(cf.data, cf.tracer, s.take(idx), d[idx])
        m = idx[miss]
        radiance[alive[m]] += beta[m] * cf.environment.radiance(d[m])
        h = idx[hit]
        spec_h = spec[h]
        radiance[alive[h[spec_h]]] += beta[h[spec_h]] * sh.emissive[spec_h]
        alive, beta, d_in, s = alive[h], beta[h], d[h], sh
        rng = rng.subset(h)
    return radiance


def trace(rf) -> dict:
    out = rf.background()
    bounces, rr = rf.options.get("reference.max_bounces"), rf.options.get("reference.rr_start")
    rf.for_chunks(lambda cf: cf.put(out, trace_paths(cf, cf.s, cf.view, cf.rng(5), bounces, rr)), streams=(5,))
    return {"radiance": out}
