"""Direct light from the environment at points, with shadow rays: the shadows pass's sample of
the sky besides its lights, GI's at its bounce hits, the reflections pass's at its points and
mirror hits (shaders/rt/paths.slang environment_light does the same on the device). One ray a
point, its direction drawn by one-sample multiple importance sampling (Veach's balance
heuristic over a mixture): from a map's distribution (rt/environment.py EnvDistribution, its
float32 steps) with probability MAP_SHARE, else from the BRDF (a lobe picked ~ its estimated
weight, as the reference path tracer: GGX's visible normals or the cosine); analytic
environments (smooth) from the BRDF alone. Its light: the environment's radiance / the mixture's
density, traced to the far distance and added like a light sample (brdf.add_light: both lobes),
so that neither a small sun nor a glossy highlight makes fireflies."""
from __future__ import annotations

import math

import numpy as np

from rt.embree import brdf, light_sampling, raygen
from rt.embree.jit import njit
from rt.embree.kernels import environment_rgb, environment_terms, equirect_uv, uniform

F = np.float32
ZERO, ONE = F(0.0), F(1.0)
PI = F(math.pi)
INV_PI = F(1.0 / math.pi)
INV_2PI2 = F(1.0 / (2.0 * math.pi * math.pi))
LAST_BELOW_ONE = F(0.99999994)
MAP_SHARE = F(0.5)  # the share of a map's samples drawn from its distribution (the rest: the BRDF's)


@njit(cache=True)
def env_dim(n_lights):
    """The environment sample's three random dimensions (strategy, direction): after every
    light's (light_sampling.direct_all draws 3 a light, direct_one 4), the same in both backends."""
    return 3 * n_lights + 4


@njit(cache=True, error_model="numpy", fastmath=True)
def map_direction(cdf, cells_u, cells_v, shift, u1, u2):
    """EnvDistribution.sample for one pair of numbers: (x, y, z, density per solid angle)."""
    lo, hi = 0, cells_u * cells_v  # the last cell whose cdf lies at or below u1
    while lo + 1 < hi:
        mid = (lo + hi) // 2
        if cdf[mid] <= u1:
            lo = mid
        else:
            hi = mid
    prob = cdf[lo + 1] - cdf[lo]
    fx = min(max((u1 - cdf[lo]) / (prob if prob > ZERO else ONE), ZERO), LAST_BELOW_ONE)
    u = (F(lo % cells_u) + fx) / F(cells_u) - shift
    theta = PI * ((F(lo // cells_u) + u2) / F(cells_v))
    phi = F(2.0) * PI * u
    st = np.sin(theta)
    density = prob * (F(cells_u * cells_v) * INV_2PI2) / max(st, F(1e-6))
    return st * np.sin(phi), np.cos(theta), -st * np.cos(phi), density


@njit(cache=True, error_model="numpy", fastmath=True)
def map_density(cdf, cells_u, cells_v, shift, x, y, z):
    """The density per solid angle with which map_direction draws unit direction (x, y, z)."""
    u, v = equirect_uv(x, y, z, shift)
    col, row = min(int(u * F(cells_u)), cells_u - 1), min(int(v * F(cells_v)), cells_v - 1)
    c = row * cells_u + col
    return (cdf[c + 1] - cdf[c]) * (F(cells_u * cells_v) * INV_2PI2) / max(np.sqrt(max(ONE - y * y, ZERO)), F(1e-6))


@njit(cache=True, error_model="numpy", fastmath=True)
def lobe_share(ggx, acc, i, base, metallic, nx, ny, nz):
    """The probability of the specular lobe at point i (the reference path tracer's estimate,
    F at n.v against the diffuse c_diff (1 - F)), 0 for Lambert; and its alpha and view."""
    if not ggx:
        return ZERO, ONE, ZERO, ZERO, ONE
    vx, vy, vz, a = acc[i, brdf.VIEW], acc[i, brdf.VIEW + 1], acc[i, brdf.VIEW + 2], acc[i, brdf.ALPHA]
    k = ONE - min(max(nx * vx + ny * vy + nz * vz, ZERO), ONE)
    w = k * k * k * k * k
    spec = diff = ZERO
    luma = (F(0.2126), F(0.7152), F(0.0722))
    for c in range(3):
        f0 = F(0.04) * (ONE - metallic) + base[c] * metallic
        f = f0 + (ONE - f0) * w
        spec += luma[c] * f
        diff += luma[c] * base[c] * (ONE - metallic) * (ONE - f)
    return (spec / max(spec + diff, F(1e-12)) if spec + diff > ZERO else ONE), a, vx, vy, vz


@njit(cache=True, error_model="numpy", fastmath=True)
def _env_step(pts, keys, dim, sky, far, acc, surf, b0, rays, nb):
    """A step's environment samples (from the map with probability MAP_SHARE where there is one,
    else the BRDF's lobes; one-sample MIS density) into rays (raygen.step_rays), from the points
    pts (raygen.step_points). sky: (environment_terms, texels, the map's distribution, its
    shift); surf: the points' (albedo, metallic, diffuse-only mask) from row b0."""
    nx, ny, nz = pts[3], pts[4], pts[5]
    terms, texels, dist, shift = sky
    albedo, metallic, diffuse = surf
    cdf, cells_u, cells_v = dist
    masked = diffuse.shape[0] > 0
    share = MAP_SHARE if cells_u > 0 else ZERO
    ggx = acc.shape[1] >= brdf.GGX_COLS
    if share == ZERO and not ggx:  # the cosine lobe alone, whatever the mask
        _cosine_env_step(pts, keys, dim, terms, texels, far, rays, nb)
        return
    for j in range(nb):
        i = b0 + j
        key = keys[j]
        u0, u1, u2 = uniform(key, dim), uniform(key, dim + 1), uniform(key, dim + 2)
        p_spec, a, vx, vy, vz = lobe_share(ggx, acc, i, albedo[i], metallic[i], nx[j], ny[j], nz[j])
        if masked and diffuse[i]:
            p_spec = ZERO
        if u0 < share:
            x, y, z, p_map = map_direction(cdf, cells_u, cells_v, shift, u1, u2)
        else:
            if (u0 - share) / (ONE - share) < p_spec:
                mx, my, mz = brdf.visible_normal(nx[j], ny[j], nz[j], vx, vy, vz, a, u1, u2)
                vm = vx * mx + vy * my + vz * mz
                x, y, z = F(2.0) * vm * mx - vx, F(2.0) * vm * my - vy, F(2.0) * vm * mz - vz
            else:
                x, y, z = raygen.cosine_about(nx[j], ny[j], nz[j], u1, u2)
            p_map = map_density(cdf, cells_u, cells_v, shift, x, y, z) if share > ZERO else ZERO
        density = share * p_map + (ONE - share) * brdf.lobes_density(p_spec, a, vx, vy, vz, nx[j], ny[j], nz[j], x, y,
                                                                            z)
        lr, lg, lb = environment_rgb(x, y, z, terms, texels)
        inv = ONE / density if density > ZERO else ZERO
        light_sampling._light_ray(j, pts, x, y, z, far, lr * inv, lg * inv, lb * inv, rays)


@njit(cache=True, error_model="numpy", fastmath=True)
def _cosine_env_step(pts, keys, dim, terms, texels, far, rays, nb):
    """_env_step where every direction comes from the cosine lobe (an analytic environment seen
    from Lambert points): the same numbers and arithmetic without the strategy's branches, so
    that the loop vectorises."""
    nx, ny, nz = pts[3], pts[4], pts[5]
    for j in range(nb):
        key = keys[j]
        x, y, z = raygen.cosine_about(nx[j], ny[j], nz[j], uniform(key, dim + 1), uniform(key, dim + 2))
        density = max(nx[j] * x + ny[j] * y + nz[j] * z, ZERO) * INV_PI
        lr, lg, lb = environment_rgb(x, y, z, terms, texels)
        inv = ONE / density if density > ZERO else ZERO
        light_sampling._light_ray(j, pts, x, y, z, far, lr * inv, lg * inv, lb * inv, rays)


@njit(cache=True, error_model="numpy", nogil=True, fastmath=True)
def env_shadow_rays(G, g0, keys, dim, env, dist, far, tr, acc, albedo, metallic):
    """One environment sample a point of G (surface_soa rows, from column g0; keys, acc,
    albedo, metallic: theirs, from row 0), its shadow ray traced into acc (tr with a scene) or,
    without one, its light added unshadowed; returns the rays traced. env: gather.env_args;
    dist: (cdf, cells u, cells v) of a map, cells 0 for the others."""
    return env_rays(G, g0, keys, dim, env, dist, far, tr, acc, albedo, metallic, np.zeros(0, np.bool_))


@njit(cache=True, error_model="numpy", nogil=True, fastmath=True)
def env_rays(G, g0, keys, dim, env, dist, far, tr, acc, albedo, metallic, diffuse):
    """env_shadow_rays where the points with diffuse[i] (none when diffuse is empty) take the
    environment's light on their diffuse lobe alone, drawn from the map and the cosine: points
    whose specular lobe another ray brings (the reflections pass's mirror and glossy rays)."""
    kind, color, horizon, zenith, ground, texels = env
    n = keys.shape[0]
    if kind == 0 or n == 0:
        return 0
    masked = diffuse.shape[0] > 0 and acc.shape[1] >= brdf.GGX_COLS
    kept = np.empty((n if masked else 0, 6), F)  # the specular sums of the diffuse-only points, kept
    if masked:
        for i in range(n):
            if diffuse[i]:
                for c in range(6):
                    kept[i, c] = acc[i, brdf.SUM_EDV + c]
    terms = environment_terms(kind, color, horizon, zenith, ground)
    shift = F(color[1]) if kind == 3 else ZERO
    packed = tr[0] == 0
    size = n if packed else 0
    origin, direction, tmax = np.empty((size, 3), F), np.empty((size, 3), F), np.empty(size, F)
    e, idx = np.empty((size, 3), F), np.empty(size, np.int32)
    rays_out = (origin, direction, tmax, e, idx)
    blk = np.empty((7, raygen.RUN), F)
    rays = raygen.step_rays(blk)
    sky, surf = (terms, texels, dist, shift), (albedo, metallic, diffuse)
    trace = raygen.tracing(tr)
    m = 0
    for b0 in range(0, n, raygen.RUN):
        b1 = min(b0 + raygen.RUN, n)
        _env_step(raygen.step_points(G, g0 + b0, g0 + b1), keys[b0:b1], dim, sky, far, acc, surf, b0, rays, b1 - b0)
        m = raygen._emit(G, g0, b0, b1 - b0, blk, m, far, rays_out, trace, acc, True)
    if packed:  # no scene to trace with (never in the shadows pass): the light unshadowed
        raygen.add_unblocked(acc, idx, direction, e, np.zeros(m, np.bool_), m, G, g0)
        m = 0
    if masked:
        for i in range(n):
            if diffuse[i]:
                for c in range(6):
                    acc[i, brdf.SUM_EDV + c] = kept[i, c]
    return m
