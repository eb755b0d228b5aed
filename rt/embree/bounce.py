"""GI's bounce rays under glTF's BRDF (option `brdf=ggx`; shaders/rt/brdf.slang's
bounce_sample is the same on the device): each point draws its next direction from its BRDF,
GGX's visible normals with probability p (the specular lobe's estimated share at n.v, as the
reference path tracer picks, at most P_SPEC_MAX) and the cosine lobe otherwise, and weighs it
by the one-sample mixture estimator

    w = f(v, l) n.l / (p pdf_ggx(l) + (1 - p) n.l / pi)

(both lobes of f: brdf.py), so that metals and glossy dielectrics get their indirect light
through the specular lobe as well as the diffuse one. The same ray also estimates the
cosine-weighted mean of the incoming light (what hybrid's rt_indirect holds) with the weight
(n.l / pi) / pdf: P_SPEC_MAX keeps the cosine lobe at half the rays or more, so that this
estimate stays unbiased and smooth on a pure metal (weights at most 2; at 0.9 hybrid's GI on
metals speckled). Random numbers: the lobe from dimension
`lobe_dim`, the direction from `dim`, `dim + 1` (cosine_about, or brdf.visible_normal)."""
from __future__ import annotations

import numpy as np

from rt.embree.brdf import INV_PI, ONE, ZERO, alpha, f0, ggx_terms, visible_normal, visible_normal_density
from rt.embree.jit import njit
from rt.embree.kernels import uniform
from rt.embree.raygen import CARRIED, DIR, RUN, _emit, cosine_about, tracing, without_light
from rt.layout import GX, GY, GZ, NX, NY, NZ

P_SPEC_MAX = np.float32(0.5)
LUMA_R, LUMA_G, LUMA_B = np.float32(0.2126), np.float32(0.7152), np.float32(0.0722)


@njit(cache=True, error_model="numpy", fastmath=True)
def _fresnel(base, metallic, w):
    """Schlick's F of one channel, w = (1 - cos)^5."""
    r = f0(base, metallic)
    return r + (ONE - r) * w


@njit(cache=True, error_model="numpy", fastmath=True)
def _lobes(base, metallic, w, dv, k):
    """One channel of f(v, l) x k: c_diff (1 - F) / pi + F D V."""
    fr = _fresnel(base, metallic, w)
    return (base * (ONE - metallic) * (ONE - fr) * INV_PI + fr * dv) * k


@njit(cache=True, error_model="numpy", fastmath=True)
def _specular(base, metallic, w, dv, k):
    """One channel of f(v, l)'s specular lobe x k: F D V."""
    return _fresnel(base, metallic, w) * dv * k


@njit(cache=True, error_model="numpy", fastmath=True)
def specular_share(nv, br, bg, bb, metallic):
    """The probability of the specular lobe at n.v = nv: F's luminance against c_diff (1 - F)'s,
    at most P_SPEC_MAX (brdf.slang's specular_share, clamped)."""
    k = ONE - min(max(nv, ZERO), ONE)
    w = k * k * k * k * k
    fr, fg, fb = _fresnel(br, metallic, w), _fresnel(bg, metallic, w), _fresnel(bb, metallic, w)
    spec = LUMA_R * fr + LUMA_G * fg + LUMA_B * fb
    c = ONE - metallic
    diff = LUMA_R * br * c * (ONE - fr) + LUMA_G * bg * c * (ONE - fg) + LUMA_B * bb * c * (ONE - fb)
    p = spec / max(spec + diff, np.float32(1e-12)) if spec + diff > ZERO else ONE
    return min(p, P_SPEC_MAX)


@njit(cache=True, error_model="numpy", fastmath=True)
def bounce_weights(n, v, l, base, metallic, a, p):
    """(w_r, w_g, w_b, w_mean, s_r, s_g, s_b): the mixture estimator's weights (module notes) of
    direction l drawn at a point of unit normal n seen from v (each an (x, y, z)), of base colour
    base (r, g, b), and the specular lobe's part of w (rt_specular); zero where l is below n."""
    nx, ny, nz = n
    vx, vy, vz = v
    lx, ly, lz = l
    br, bg, bb = base
    nl = nx * lx + ny * ly + nz * lz
    if not nl > ZERO:
        return ZERO, ZERO, ZERO, ZERO, ZERO, ZERO, ZERO
    w, dv = ggx_terms(nx, ny, nz, vx, vy, vz, lx, ly, lz, a)
    pdf = p * visible_normal_density(nx, ny, nz, vx, vy, vz, lx, ly, lz, a) + (ONE - p) * nl * INV_PI
    if not pdf > ZERO:
        return ZERO, ZERO, ZERO, ZERO, ZERO, ZERO, ZERO
    k = nl / pdf
    return (_lobes(br, metallic, w, dv, k), _lobes(bg, metallic, w, dv, k), _lobes(bb, metallic, w, dv, k),
            k * INV_PI, _specular(br, metallic, w, dv, k), _specular(bg, metallic, w, dv, k),
            _specular(bb, metallic, w, dv, k))


@njit(cache=True, error_model="numpy", fastmath=True)
def bounce_direction(nx, ny, nz, vx, vy, vz, a, p, ul, u0, u1):
    """A direction from the lobe that ul picks (specular where ul < p)."""
    if ul < p:
        mx, my, mz = visible_normal(nx, ny, nz, vx, vy, vz, a, u0, u1)
        vm = vx * mx + vy * my + vz * mz
        return 2 * vm * mx - vx, 2 * vm * my - vy, 2 * vm * mz - vz
    return cosine_about(nx, ny, nz, u0, u1)


@njit(cache=True, error_model="numpy", nogil=True, fastmath=True)
def brdf_live(G, g0, keys, dim, lobe_dim, surf, tmax_value, packed, tr, weights):
    """hemisphere_live (raygen.py) with directions from the points' BRDF: point i (surf: its
    view V[i], towards the viewer, and material albedo[i], metallic[i], rough[i]) gets its ray
    packed into packed (origin, direction, tmax, index) where it leaves above both its shading
    and its true surface, and weights[i] = (w_r, w_g, w_b, w_mean, s_r, s_g, s_b) (bounce_weights;
    zero for a point whose ray is not packed). Returns the count."""
    V, albedo, metallic, rough = surf
    packed = without_light(packed)
    n = keys.shape[0]
    blk = np.empty((7, RUN), np.float32)
    trace = tracing(tr)
    m = 0
    for s0 in range(0, n, RUN):
        s1 = min(s0 + RUN, n)
        for j in range(s1 - s0):
            i = s0 + j
            c = g0 + i
            nx, ny, nz = G[NX, c], G[NY, c], G[NZ, c]
            vx, vy, vz = V[i, 0], V[i, 1], V[i, 2]
            a = alpha(rough[i])
            br, bg, bb = albedo[i, 0], albedo[i, 1], albedo[i, 2]
            p = specular_share(nx * vx + ny * vy + nz * vz, br, bg, bb, metallic[i])
            key = keys[i]
            lx, ly, lz = bounce_direction(nx, ny, nz, vx, vy, vz, a, p, uniform(key, lobe_dim), uniform(key, dim),
                                          uniform(key, dim + 1))
            ws = bounce_weights((nx, ny, nz), (vx, vy, vz), (lx, ly, lz), (br, bg, bb), metallic[i], a, p)
            above = G[GX, c] * lx + G[GY, c] * ly + G[GZ, c] * lz > ZERO and ws[3] > ZERO
            blk[DIR, j], blk[DIR + 1, j], blk[DIR + 2, j] = lx, ly, lz
            blk[CARRIED, j] = ONE if above else ZERO
            for k in range(7):
                weights[i, k] = ws[k] if above else ZERO
        m = _emit(G, g0, s0, s1 - s0, blk, m, tmax_value, packed, trace, weights, False)
    return m
