"""Fused ray generators for the tracing threads: sample, build and pack the rays of a chunk in
one pass over its points, in float32, writing only the rays worth tracing.

Each generator writes ray j at slot m and advances m by 1 only if the ray carries something
(branch-free compaction): origins, directions, tmax and the light it carries come out packed
in front of the buffers, with `idx[j]` the point the ray belongs to, and the count returned.
The packed buffers go to Embree as they are. Serial and GIL-free: one call per chunk per thread.

sin/cos come from a short polynomial (`sin_turns`), which vectorises where libm's does not and
is accurate to 4e-7, far below the sampling noise.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from rt.kernels import uniform

F = np.float32
ZERO, HALF, ONE, TWO = F(0.0), F(0.5), F(1.0), F(2.0)
TAU = F(2.0 * math.pi)
S3, S5, S7, S9, S11 = F(-1 / 6), F(1 / 120), F(-1 / 5040), F(1 / 362880), F(-1 / 39916800)
TINY = F(1e-12)


@njit(cache=True, error_model="numpy", inline="always", fastmath=True)
def sin_turns(u):
    """sin(2 pi u) for u >= 0 (float32, branch-free)."""
    x = u - F(int(u + HALF))  # [-1/2, 1/2] turns
    x = min(x, HALF - x)  # fold onto [-1/4, 1/4]: sin(pi - t) = sin(t)
    x = max(x, -HALF - x)
    t = x * TAU
    t2 = t * t
    return t * (ONE + t2 * (S3 + t2 * (S5 + t2 * (S7 + t2 * (S9 + t2 * S11)))))


@njit(cache=True, error_model="numpy", inline="always", fastmath=True)
def cos_turns(u):
    return sin_turns(u + F(0.25))


@njit(cache=True, error_model="numpy", inline="always", fastmath=True)
def offset(eps, px, py, pz):
    """How far ray origins are nudged off a surface (embreex has no tnear)."""
    return eps * (ONE + max(abs(px), abs(py), abs(pz)) * F(1e-3))


@njit(cache=True, error_model="numpy", inline="always", fastmath=True)
def put(m, i, P, NG, s, dx, dy, dz, t, origin, direction, tmax, idx):
    origin[m, 0] = P[i, 0] + NG[i, 0] * s
    origin[m, 1] = P[i, 1] + NG[i, 1] * s
    origin[m, 2] = P[i, 2] + NG[i, 2] * s
    direction[m, 0], direction[m, 1], direction[m, 2] = dx, dy, dz
    tmax[m] = t
    idx[m] = i


@njit(cache=True, error_model="numpy", inline="always", fastmath=True)
def about(nx, ny, nz, x, y, z):
    """(x, y, z) in the orthonormal basis about n (Duff et al. 2017)."""
    sign = ONE if nz >= ZERO else -ONE
    a = -ONE / (sign + nz)
    b = nx * ny * a
    return ((ONE + sign * nx * nx * a) * x + b * y + nx * z,
            sign * b * x + (sign + ny * ny * a) * y + ny * z,
            -sign * nx * x - ny * y + nz * z)


@njit(cache=True, error_model="numpy", nogil=True, fastmath=True)
def hemisphere_live(P, N, NG, keys, dim, eps, tmax_value, origin, direction, tmax, idx):
    """Cosine-weighted rays about N; packs those above the true surface (NG). Returns the count."""
    m = 0
    for i in range(P.shape[0]):
        u0, u1 = uniform(keys[i], dim), uniform(keys[i], dim + 1)
        r = np.sqrt(u0)
        dx, dy, dz = about(N[i, 0], N[i, 1], N[i, 2], r * cos_turns(u1), r * sin_turns(u1),
                           np.sqrt(max(ZERO, ONE - u0)))
        put(m, i, P, NG, offset(eps, P[i, 0], P[i, 1], P[i, 2]), dx, dy, dz, tmax_value, origin, direction, tmax, idx)
        m += NG[i, 0] * dx + NG[i, 1] * dy + NG[i, 2] * dz > ZERO
    return m


@njit(cache=True, error_model="numpy", nogil=True, fastmath=True)
def cosine_dirs(N, keys, dim, out):
    """Cosine-weighted directions about N (not packed: some may point below the true surface)."""
    for i in range(N.shape[0]):
        u0, u1 = uniform(keys[i], dim), uniform(keys[i], dim + 1)
        r = np.sqrt(u0)
        out[i, 0], out[i, 1], out[i, 2] = about(N[i, 0], N[i, 1], N[i, 2], r * cos_turns(u1), r * sin_turns(u1),
                                                np.sqrt(max(ZERO, ONE - u0)))


@njit(cache=True, error_model="numpy", inline="always", fastmath=True)
def _keep_light(m, i, P, N, NG, eps, dx, dy, dz, dist, ex, ey, ez, origin, direction, tmax, e, idx):
    """Write a shadow ray with its unshadowed irradiance x cos; returns 1 if it carries light."""
    cs = N[i, 0] * dx + N[i, 1] * dy + N[i, 2] * dz
    cg = NG[i, 0] * dx + NG[i, 1] * dy + NG[i, 2] * dz
    cs = cs if (cs > ZERO and cg > ZERO) else ZERO
    s = offset(eps, P[i, 0], P[i, 1], P[i, 2])
    put(m, i, P, NG, s, dx, dy, dz, max(dist - TWO * s, s), origin, direction, tmax, idx)
    ex, ey, ez = ex * cs, ey * cs, ez * cs
    e[m, 0], e[m, 1], e[m, 2] = ex, ey, ez
    return (ex > ZERO) | (ey > ZERO) | (ez > ZERO)


@njit(cache=True, error_model="numpy", inline="always", fastmath=True)
def _sun(k, u0, u1, ldir, ang):
    """A direction towards sun k, optionally a disc of angular radius ang."""
    ax, ay, az = -ldir[k, 0], -ldir[k, 1], -ldir[k, 2]
    if ang[k] > ZERO:
        ct = ONE - u0 * (ONE - F(math.cos(ang[k])))
        st = np.sqrt(max(ZERO, ONE - ct * ct))
        return about(ax, ay, az, st * cos_turns(u1), st * sin_turns(u1), ct)
    return ax, ay, az


@njit(cache=True, error_model="numpy", inline="always", fastmath=True)
def _towards(k, px, py, pz, spot, lpos, ldir, cos_out, spot_scale):
    """Point or spot light k seen from p: (dir, dist, attenuation: 1/d^2 x the spot's cone)."""
    vx, vy, vz = lpos[k, 0] - px, lpos[k, 1] - py, lpos[k, 2] - pz
    d2 = max(vx * vx + vy * vy + vz * vz, TINY)
    inv = ONE / np.sqrt(d2)
    dx, dy, dz = vx * inv, vy * inv, vz * inv
    att = inv * inv
    if spot:  # glTF's squared linear ramp
        t = min(max((-(dx * ldir[k, 0] + dy * ldir[k, 1] + dz * ldir[k, 2]) - cos_out[k]) * spot_scale[k], ZERO), ONE)
        att *= t * t
    return dx, dy, dz, d2 * inv, att


@njit(cache=True, error_model="numpy", nogil=True, fastmath=True)
def analytic_shadow_rays(k, P, N, NG, keys, dim, analytic, eps, far, origin, direction, tmax, e, idx):
    """Shadow rays towards analytic light k from every point, packed; returns the count.
    One loop per light type, so each stays short and branch-free."""
    kind, lpos, ldir, lrad, cos_out, spot_scale, ang, lum = analytic
    r0, r1, r2 = lrad[k, 0], lrad[k, 1], lrad[k, 2]
    m = 0
    if kind[k] == 2:
        for i in range(P.shape[0]):
            dx, dy, dz = _sun(k, uniform(keys[i], dim), uniform(keys[i], dim + 1), ldir, ang)
            m += _keep_light(m, i, P, N, NG, eps, dx, dy, dz, far, r0, r1, r2, origin, direction, tmax, e, idx)
    else:
        spot = kind[k] == 1
        for i in range(P.shape[0]):
            dx, dy, dz, dist, att = _towards(k, P[i, 0], P[i, 1], P[i, 2], spot, lpos, ldir, cos_out, spot_scale)
            m += _keep_light(m, i, P, N, NG, eps, dx, dy, dz, dist, r0 * att, r1 * att, r2 * att, origin, direction,
                             tmax, e, idx)
    return m


@njit(cache=True, error_model="numpy", inline="always", fastmath=True)
def _emitter(lo, hi, px, py, pz, u0, u1, u2, rows, keep, alias):
    """A point on one of the triangles rows[lo:hi] of a cluster (alias method: O(1)), as
    (dir, dist short of the emitter, Le x cos_light / d^2 / pdf_area)."""
    x = u0 * F(hi - lo)
    slot = min(int(x), hi - lo - 1)
    j = lo + slot
    j = j if (x - F(slot)) < keep[j] else lo + alias[j]
    su = np.sqrt(u1)
    b1, b2 = su * (ONE - u2), su * u2
    vx = rows[j, 0] + rows[j, 3] * b1 + rows[j, 6] * b2 - px
    vy = rows[j, 1] + rows[j, 4] * b1 + rows[j, 7] * b2 - py
    vz = rows[j, 2] + rows[j, 5] * b1 + rows[j, 8] * b2 - pz
    d2 = max(vx * vx + vy * vy + vz * vz, TINY)
    inv = ONE / np.sqrt(d2)
    dx, dy, dz = vx * inv, vy * inv, vz * inv
    cl = -(rows[j, 9] * dx + rows[j, 10] * dy + rows[j, 11] * dz)
    cl = abs(cl) if rows[j, 15] > ZERO else max(cl, ZERO)
    g = cl * inv * inv
    return dx, dy, dz, d2 * inv * F(1.0 - 1e-4), rows[j, 12] * g, rows[j, 13] * g, rows[j, 14] * g


@njit(cache=True, error_model="numpy", nogil=True, fastmath=True)
def cluster_shadow_rays(lo, hi, P, N, NG, keys, dim, rows, keep, alias, eps, origin, direction, tmax, e, idx):
    """Shadow rays towards one emissive cluster (emitter rows lo:hi) from every point, packed."""
    m = 0
    for i in range(P.shape[0]):
        key = keys[i]
        dx, dy, dz, dist, ex, ey, ez = _emitter(lo, hi, P[i, 0], P[i, 1], P[i, 2], uniform(key, dim),
                                                uniform(key, dim + 1), uniform(key, dim + 2), rows, keep, alias)
        m += _keep_light(m, i, P, N, NG, eps, dx, dy, dz, dist, ex, ey, ez, origin, direction, tmax, e, idx)
    return m


BLOCK = 64  # points whose light weights are computed together, one light at a time (vectorises)
SCRATCH_ROWS = 9  # one_light_shadow_rays' scratch rows besides the weights


@njit(cache=True, error_model="numpy", inline="always", fastmath=True)
def _light_weights(soa, nb, guide, w):
    """w[k, i]: light k's estimated contribution at block point i (soa: px, py, pz, nx, ny, nz
    rows). Analytic lights exactly (up to the albedo); emissive clusters by a bound from their
    bounding sphere, never zero where some part could contribute (the cosine bound grows with
    the cluster's angular size). One branch-free loop over the block per light."""
    lx, ly, lz, sx, sy, sz, lum, cos_out, spot_scale, sun, cx, cy, cz, radius, power = guide
    na = lx.shape[0]
    px, py, pz, nx, ny, nz = soa[0], soa[1], soa[2], soa[3], soa[4], soa[5]
    for k in range(na):
        qx, qy, qz, dx, dy, dz = lx[k], ly[k], lz[k], sx[k], sy[k], sz[k]
        co, sc, lk, is_sun = cos_out[k], spot_scale[k], lum[k], sun[k]
        row = w[k]
        for i in range(nb):
            vx, vy, vz = qx - px[i], qy - py[i], qz - pz[i]
            d2 = max(vx * vx + vy * vy + vz * vz, TINY)
            inv = ONE / np.sqrt(d2)
            t = min(max((-(vx * dx + vy * dy + vz * dz) * inv - co) * sc, ZERO), ONE)
            local = max((nx[i] * vx + ny[i] * vy + nz[i] * vz) * inv, ZERO) * inv * inv * t * t  # point, spot
            far = max(-(nx[i] * dx + ny[i] * dy + nz[i] * dz), ZERO) + F(1e-6)  # sun
            row[i] = lk * (far if is_sun else local)
    for j in range(cx.shape[0]):
        qx, qy, qz, r, pj = cx[j], cy[j], cz[j], radius[j], power[j]
        row = w[na + j]
        for i in range(nb):
            vx, vy, vz = qx - px[i], qy - py[i], qz - pz[i]
            d2 = max(vx * vx + vy * vy + vz * vz, TINY)
            inv = ONE / np.sqrt(d2)
            sin_r = min(r * inv, ONE)
            cb = min(max((nx[i] * vx + ny[i] * vy + nz[i] * vz) * inv + sin_r, ZERO), ONE)
            cb = cb if sin_r < ONE else ONE
            row[i] = pj * max(cb, F(0.02)) / max(d2 - r * r, r * r * F(0.25) + TINY)


@njit(cache=True, error_model="numpy", nogil=True, fastmath=True)
def one_light_shadow_rays(P, N, NG, keys, dim, analytic, emitters, guide, eps, far, weights, origin, direction, tmax,
                          e, idx):
    """One light per point, picked with probability ~ its estimated contribution there, sampled
    and divided by that probability (unbiased: accumulates to all lights); packed.
    weights: (lights + SCRATCH_ROWS, BLOCK) scratch."""
    kind, lpos, ldir, lrad, cos_out, spot_scale, ang, lum = analytic
    start, rows, keep, alias = emitters
    count_analytic = kind.shape[0]
    n_lights = weights.shape[0] - SCRATCH_ROWS
    w = weights[:n_lights]  # weights, then their running sums over the lights
    soa, total, target, pick = weights[n_lights:n_lights + 6], weights[-3], weights[-2], weights[-1]
    m = 0
    for b0 in range(0, P.shape[0], BLOCK):
        nb = min(BLOCK, P.shape[0] - b0)
        for i in range(nb):
            for a in range(3):
                soa[a, i] = P[b0 + i, a]
                soa[3 + a, i] = N[b0 + i, a]
        _light_weights(soa, nb, guide, w)
        for k in range(1, n_lights):  # running sums, a light at a time across the block
            for i in range(nb):
                w[k, i] += w[k - 1, i]
        for i in range(nb):
            total[i] = w[n_lights - 1, i]
            target[i] = uniform(keys[b0 + i], dim) * total[i]
            pick[i] = ZERO
        for k in range(n_lights - 1):  # the light picked: how many running sums lie below the target
            for i in range(nb):
                pick[i] += ONE if w[k, i] <= target[i] else ZERO
        for b in range(nb):
            i = b0 + b
            px, py, pz = P[i, 0], P[i, 1], P[i, 2]
            k = int(pick[b])
            wk = w[k, b] - (w[k - 1, b] if k > 0 else ZERO)
            prob = wk / total[b] if total[b] > ZERO else ZERO
            inv = ONE / prob if prob > ZERO else ZERO
            key = keys[i]
            u1, u2, u3 = uniform(key, dim + 1), uniform(key, dim + 2), uniform(key, dim + 3)
            if k < count_analytic:
                if kind[k] == 2:
                    dx, dy, dz = _sun(k, u1, u2, ldir, ang)
                    dist, att = far, ONE
                else:
                    dx, dy, dz, dist, att = _towards(k, px, py, pz, kind[k] == 1, lpos, ldir, cos_out, spot_scale)
                att *= inv
                ex, ey, ez = lrad[k, 0] * att, lrad[k, 1] * att, lrad[k, 2] * att
            else:
                c = k - count_analytic
                dx, dy, dz, dist, ex, ey, ez = _emitter(start[c], start[c + 1], px, py, pz, u1, u2, u3, rows, keep,
                                                        alias)
                ex, ey, ez = ex * inv, ey * inv, ez * inv
            m += _keep_light(m, i, P, N, NG, eps, dx, dy, dz, dist, ex, ey, ez, origin, direction, tmax, e, idx)
    return m


@njit(cache=True, error_model="numpy", nogil=True)
def add_unblocked(total, idx, e, blocked, m):
    """total[idx[j]] += e[j] for the first m packed rays that were not blocked."""
    for j in range(m):
        if not blocked[j]:
            i = idx[j]
            total[i, 0] += e[j, 0]
            total[i, 1] += e[j, 1]
            total[i, 2] += e[j, 2]


@njit(cache=True, error_model="numpy", nogil=True)
def add_open(count, idx, blocked, m):
    for j in range(m):
        if not blocked[j]:
            count[idx[j]] += ONE
