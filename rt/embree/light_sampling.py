"""Light sampling for the Embree kernels: shadow rays towards the scene's lights, made, packed or
traced as rt/embree/raygen.py's generators do (points as structure-of-arrays rows, steps of
raygen.RUN or BLOCK points, rays carrying something kept in front of the buffers).

- analytic lights one by one (analytic_shadow_rays) and emitter clusters by alias tables
  (cluster_shadow_rays): direct_all, every light a point;
- one light a point, picked with probability ~ its estimated contribution there
  (one_light_shadow_rays: the weights, the draws, the pick, the picked light's row, the rays),
  with multiple importance sampling weights for the reference path tracer (_mis_weights,
  emission_weights): direct_one;
- direct_all and direct_one: the passes' entry points, tracing or packing.
"""
from __future__ import annotations

import numpy as np

from rt.embree.brdf import ALPHA, P_SPEC, SUM_EDVW, VIEW, lobes_density
from rt.embree.jit import njit
from rt.embree.kernels import uniform
from rt.embree.raygen import (
    INV_PI,
    ONE,
    RUN,
    TINY,
    ZERO,
    F,
    _emit,
    about,
    add_unblocked,
    cos_turns,
    mis_weight,
    sin_turns,
    step_points,
    step_rays,
    tracing,
)
from rt.layout import (
    AREA_PDF,
    CONE_COS,
    CONE_SCALE,
    EDGE1,
    EDGE2,
    EMISSION,
    FACE_NORMAL,
    INV_PROB,
    IS_EMITTER,
    IS_SUN,
    LIGHT_ROW,
    PICKED_ROWS,
    POSITION,
    RADIANCE,
    SUN_COS,
    TO_SUN,
    TWO_SIDED,
    VERTEX,
)

# ---- every light a point: analytic lights, emitter clusters -----------------------------------


@njit(cache=True, error_model="numpy", fastmath=True)
def _light_ray(j, pts, x, y, z, dist, ex, ey, ez, rays):
    """Step slot j of rays (raygen.step_rays) from point j of pts (raygen.step_points): a shadow
    ray towards (x, y, z) at distance dist, with its unshadowed irradiance x cos: zero where the
    light is below the shading or the true surface."""
    nx, ny, nz, gx, gy, gz = pts[3], pts[4], pts[5], pts[6], pts[7], pts[8]
    dx, dy, dz, dd, er, eg, eb = rays
    cs = nx[j] * x + ny[j] * y + nz[j] * z
    cg = gx[j] * x + gy[j] * y + gz[j] * z
    cs = cs if (cs > ZERO and cg > ZERO) else ZERO
    dx[j], dy[j], dz[j], dd[j] = x, y, z, dist
    er[j], eg[j], eb[j] = ex * cs, ey * cs, ez * cs


@njit(cache=True, error_model="numpy", fastmath=True)
def _sun(ax, ay, az, cos_ang, u0, u1):
    """A direction in the cone of half-angle acos(cos_ang) about (ax, ay, az), the direction to
    a sun (exactly that direction for a point-like sun: cos_ang = 1)."""
    ct = ONE - u0 * (ONE - cos_ang)
    st = np.sqrt(max(ZERO, ONE - ct * ct))
    return about(ax, ay, az, st * cos_turns(u1), st * sin_turns(u1), ct)


@njit(cache=True, error_model="numpy", fastmath=True)
def _analytic_step(k, pts, keys, dim, analytic, far, rays, nb):
    """One loop per light type, so each stays short and branch-free; the light's parameters are
    read into locals first (loads from the light arrays inside the loop would have to be
    repeated, as the compiler cannot rule out that the stores change them, and do not vectorise)."""
    px, py, pz = pts[0], pts[1], pts[2]
    kind, lpos, ldir, lrad, cos_out, spot_scale, cos_ang, lum = analytic
    r0, r1, r2 = lrad[k, 0], lrad[k, 1], lrad[k, 2]
    if kind[k] == 2:
        ax, ay, az, ca = -ldir[k, 0], -ldir[k, 1], -ldir[k, 2], cos_ang[k]
        for j in range(nb):
            x, y, z = _sun(ax, ay, az, ca, uniform(keys[j], dim), uniform(keys[j], dim + 1))
            _light_ray(j, pts, x, y, z, far, r0, r1, r2, rays)
        return
    qx, qy, qz, sx, sy, sz = lpos[k, 0], lpos[k, 1], lpos[k, 2], ldir[k, 0], ldir[k, 1], ldir[k, 2]
    co, ss = (cos_out[k], spot_scale[k]) if kind[k] == 1 else (F(-2.0), ONE)  # a point light's cone is never cut
    for j in range(nb):
        vx, vy, vz = qx - px[j], qy - py[j], qz - pz[j]
        d2 = max(vx * vx + vy * vy + vz * vz, TINY)
        inv = ONE / np.sqrt(d2)
        x, y, z = vx * inv, vy * inv, vz * inv
        t = min(max((-(x * sx + y * sy + z * sz) - co) * ss, ZERO), ONE)  # glTF's squared linear ramp
        att = inv * inv * t * t
        _light_ray(j, pts, x, y, z, d2 * inv, r0 * att, r1 * att, r2 * att, rays)


@njit(cache=True, error_model="numpy", nogil=True, fastmath=True)
def analytic_shadow_rays(k, G, g0, keys, dim, analytic, far, packed, tr, acc):
    """Shadow rays towards analytic light k from every point of G (surface_soa rows), packed
    into packed (origin, direction, tmax, light, index) (or traced into acc if tr has a scene);
    returns the count."""
    n = keys.shape[0]
    blk = np.empty((7, RUN), np.float32)
    rays = step_rays(blk)
    trace = tracing(tr)
    m = 0
    for b0 in range(0, n, RUN):
        b1 = min(b0 + RUN, n)
        _analytic_step(k, step_points(G, g0 + b0, g0 + b1), keys[b0:b1], dim, analytic, far, rays, b1 - b0)
        m = _emit(G, g0, b0, b1 - b0, blk, m, far, packed, trace, acc, True)
    return m


@njit(cache=True, error_model="numpy", fastmath=True)
def _toward_emitter(S, j, u, w, px, py, pz):
    """From (px, py, pz) towards a uniform point (numbers u, w) on the triangle of light row
    S[:, j] (layout.py): the unit direction, the squared distance, 1 / the distance, and
    cos_light / d^2 (0 behind a one-sided emitter)."""
    su = np.sqrt(u)
    b1, b2 = su * (ONE - w), su * w
    vx = S[VERTEX, j] + S[EDGE1, j] * b1 + S[EDGE2, j] * b2 - px
    vy = S[VERTEX + 1, j] + S[EDGE1 + 1, j] * b1 + S[EDGE2 + 1, j] * b2 - py
    vz = S[VERTEX + 2, j] + S[EDGE1 + 2, j] * b1 + S[EDGE2 + 2, j] * b2 - pz
    d2 = max(vx * vx + vy * vy + vz * vz, TINY)
    inv = ONE / np.sqrt(d2)
    x, y, z = vx * inv, vy * inv, vz * inv
    cl = -(S[FACE_NORMAL, j] * x + S[FACE_NORMAL + 1, j] * y + S[FACE_NORMAL + 2, j] * z)
    cl = abs(cl) if S[TWO_SIDED, j] > ZERO else max(cl, ZERO)
    return x, y, z, d2, inv, cl * inv * inv


@njit(cache=True, error_model="numpy", fastmath=True)
def _cluster_step(lo, hi, pts, keys, dim, cluster, rays, U, S, nb):
    """Three loops: each point's numbers (vectorises: the hash is integer arithmetic), the
    triangle it picks (alias method: dependent loads) with its row copied into the columns of
    S, then the rays to points on those triangles, from unit-stride rows (vectorises; reading
    rows[t] there would keep it scalar). cluster: the emitter rows and their alias table (rows,
    keep, alias)."""
    px, py, pz = pts[0], pts[1], pts[2]
    rows, keep, alias = cluster
    span = F(hi - lo)
    for j in range(nb):
        key = keys[j]
        U[0, j], U[1, j], U[2, j] = uniform(key, dim) * span, uniform(key, dim + 1), uniform(key, dim + 2)
    for j in range(nb):
        x = U[0, j]
        slot = min(int(x), hi - lo - 1)
        t = lo + slot
        t = t if (x - F(slot)) < keep[t] else lo + alias[t]
        for c in range(LIGHT_ROW):
            S[c, j] = rows[t, c]
    for j in range(nb):
        x, y, z, d2, inv, g = _toward_emitter(S, j, U[1, j], U[2, j], px[j], py[j], pz[j])
        _light_ray(j, pts, x, y, z, d2 * inv * F(1.0 - 1e-4), S[EMISSION, j] * g, S[EMISSION + 1, j] * g,
                   S[EMISSION + 2, j] * g, rays)


@njit(cache=True, error_model="numpy", nogil=True, fastmath=True)
def cluster_shadow_rays(lo, hi, G, g0, keys, dim, cluster, packed, tr, acc):
    """Shadow rays towards one emissive cluster (emitter rows lo:hi of cluster: rows, keep,
    alias) from every point of G, packed (or traced into acc if tr has a scene)."""
    n = keys.shape[0]
    blk = np.empty((7, RUN), np.float32)
    rays = step_rays(blk)
    U, S = np.empty((3, RUN), np.float32), np.empty((LIGHT_ROW, RUN), np.float32)
    trace = tracing(tr)
    m = 0
    for b0 in range(0, n, RUN):
        b1 = min(b0 + RUN, n)
        _cluster_step(lo, hi, step_points(G, g0 + b0, g0 + b1), keys[b0:b1], dim, cluster, rays, U, S, b1 - b0)
        m = _emit(G, g0, b0, b1 - b0, blk, m, ZERO, packed, trace, acc, True)
    return m


BLOCK = 256  # points whose light weights are computed together, one light at a time (vectorises);
# the fastest of 32-512 on many-light scenes (report/HISTORY.md, eighth round)


SCRATCH_ROWS = 6  # one_light_shadow_rays' scratch rows besides the weights


@njit(cache=True, error_model="numpy", fastmath=True)
def _light_weights(px, py, pz, nx, ny, nz, nb, guide, w, run):
    """w[k, i]: the running sum over lights 0..k of their estimated contribution at block point
    i (run: scratch, left holding the total). Analytic lights exactly (up to the albedo);
    emissive clusters by a bound from their bounding sphere, never zero where some part could
    contribute (the cosine bound grows with the cluster's angular size). One branch-free loop
    over the block per light, specialised by the kind of light."""
    lx, ly, lz, sx, sy, sz, lum, cos_out, spot_scale, sun, cx, cy, cz, radius, power = guide
    na = lx.shape[0]
    for i in range(nb):
        run[i] = ZERO
    for k in range(na):
        qx, qy, qz, dx, dy, dz = lx[k], ly[k], lz[k], sx[k], sy[k], sz[k]
        co, sc, lk = cos_out[k], spot_scale[k], lum[k]
        row = w[k]
        if sun[k]:
            for i in range(nb):
                run[i] += lk * (max(-(nx[i] * dx + ny[i] * dy + nz[i] * dz), ZERO) + F(1e-6))
                row[i] = run[i]
        elif co > F(-1.5):  # a spot: its cone
            for i in range(nb):
                vx, vy, vz = qx - px[i], qy - py[i], qz - pz[i]
                d2 = max(vx * vx + vy * vy + vz * vz, TINY)
                inv = ONE / np.sqrt(d2)
                t = min(max((-(vx * dx + vy * dy + vz * dz) * inv - co) * sc, ZERO), ONE)
                run[i] += lk * (max((nx[i] * vx + ny[i] * vy + nz[i] * vz) * inv, ZERO) * inv * inv * t * t)
                row[i] = run[i]
        else:  # a point light
            for i in range(nb):
                vx, vy, vz = qx - px[i], qy - py[i], qz - pz[i]
                d2 = max(vx * vx + vy * vy + vz * vz, TINY)
                inv = ONE / np.sqrt(d2)
                run[i] += lk * (max((nx[i] * vx + ny[i] * vy + nz[i] * vz) * inv, ZERO) * inv * inv)
                row[i] = run[i]
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
            run[i] += pj * max(cb, F(0.02)) / max(d2 - r * r, r * r * F(0.25) + TINY)
            row[i] = run[i]


@njit(cache=True, error_model="numpy", fastmath=True)
def _draw_targets(keys, dim, nb, total, target, pick, u1, u2, u3):
    """Per point: where in its running sums the pick falls, and the numbers that sample the
    light picked (vectorises: the hash is integer arithmetic)."""
    for i in range(nb):
        key = keys[i]
        target[i] = uniform(key, dim) * total[i]
        u1[i], u2[i], u3[i] = uniform(key, dim + 1), uniform(key, dim + 2), uniform(key, dim + 3)
        pick[i] = ZERO


@njit(cache=True, error_model="numpy", fastmath=True)
def _draw_samples(keys, dim, nb, u1, u2, u3):
    """_draw_targets' numbers that sample the light, for a pick that needs no target."""
    for i in range(nb):
        key = keys[i]
        u1[i], u2[i], u3[i] = uniform(key, dim + 1), uniform(key, dim + 2), uniform(key, dim + 3)


@njit(cache=True, error_model="numpy", nogil=True)
def analytic_rows(analytic):
    """One light row (layout.py) per analytic light."""
    kind, lpos, ldir, lrad, cos_out, spot_scale, cos_ang, lum = analytic
    out = np.zeros((kind.shape[0], LIGHT_ROW), np.float32)
    for k in range(kind.shape[0]):
        for a in range(3):
            out[k, POSITION + a], out[k, TO_SUN + a], out[k, RADIANCE + a] = lpos[k, a], -ldir[k, a], lrad[k, a]
        spot = kind[k] == 1
        out[k, CONE_COS] = cos_out[k] if spot else F(-2.0)
        out[k, CONE_SCALE] = spot_scale[k] if spot else ONE
        out[k, SUN_COS] = cos_ang[k]
        out[k, IS_SUN] = ONE if kind[k] == 2 else ZERO
    return out


@njit(cache=True, error_model="numpy", fastmath=True)
def _gather_picked(nb, na, pick, w, total, u1, table, emitters, S):
    """S[:LIGHT_ROW, b]: the row of what point b picked (the analytic light's, or for an
    emissive cluster the triangle drawn from it with u1, alias method), S[INV_PROB, b] 1 / the
    pick's probability (0 where the light cannot contribute), S[IS_EMITTER, b] 1 for an
    emitter. A serial
    loop of loads, so that the sampling loop after it reads unit-stride rows and vectorises."""
    start, rows, keep, alias = emitters
    for b in range(nb):
        kk = int(pick[b])
        wk = w[kk, b] - (w[kk - 1, b] if kk > 0 else ZERO)
        prob = wk / total[b] if total[b] > ZERO else ZERO
        S[INV_PROB, b] = ONE / prob if prob > ZERO else ZERO
        if kk < na:
            for c in range(LIGHT_ROW):
                S[c, b] = table[kk, c]
            S[IS_EMITTER, b] = ZERO
        else:
            lo, hi = start[kk - na], start[kk - na + 1]
            x = u1[b] * F(hi - lo)
            slot = min(int(x), hi - lo - 1)
            j = lo + slot
            j = j if (x - F(slot)) < keep[j] else lo + alias[j]
            for c in range(LIGHT_ROW):
                S[c, b] = rows[j, c]
            S[IS_EMITTER, b] = ONE


@njit(cache=True, error_model="numpy", fastmath=True)
def _picked_rays(nb, S, u, pts, far, rays):
    """The shadow ray of every point towards the light it picked (rows S, _gather_picked),
    divided by the pick's probability: one branch-free loop over unit-stride rows that
    computes a sun's cone sample (_sun), a point or spot light's direction (its distance and
    glTF's squared linear ramp, as _analytic_step) and a point on an emitting triangle
    (Le x cos_light / d^2 / pdf_area, as _cluster_step), and keeps the one that applies.
    u: the numbers that sample the light (u1, u2, u3: _draw_targets)."""
    u1, u2, u3 = u
    px, py, pz = pts[0], pts[1], pts[2]
    for b in range(nb):
        # a sun: a direction in its cone
        ax, ay, az = S[TO_SUN, b], S[TO_SUN + 1, b], S[TO_SUN + 2, b]
        ct = ONE - u1[b] * (ONE - S[SUN_COS, b])
        st = np.sqrt(max(ZERO, ONE - ct * ct))
        ux, uy, uz = about(ax, ay, az, st * cos_turns(u2[b]), st * sin_turns(u2[b]), ct)
        # a point or spot light: glTF's squared linear ramp (TO_SUN holds a spot's axis, reversed)
        vx, vy, vz = S[POSITION, b] - px[b], S[POSITION + 1, b] - py[b], S[POSITION + 2, b] - pz[b]
        d2 = max(vx * vx + vy * vy + vz * vz, TINY)
        r = ONE / np.sqrt(d2)
        qx, qy, qz = vx * r, vy * r, vz * r
        t = min(max(((qx * ax + qy * ay + qz * az) - S[CONE_COS, b]) * S[CONE_SCALE, b], ZERO), ONE)
        is_sun = S[IS_SUN, b] > ZERO
        att = ONE if is_sun else r * r * t * t
        # a point on an emitting triangle: Le x cos_light / d^2 / pdf_area
        mx, my, mz, e2, ri, g = _toward_emitter(S, b, u2[b], u3[b], px[b], py[b], pz[b])
        inv = S[INV_PROB, b]
        if S[IS_EMITTER, b] > ZERO:
            x, y, z, dist = mx, my, mz, e2 * ri * F(1.0 - 1e-4)
            ex, ey, ez = S[EMISSION, b] * g * inv, S[EMISSION + 1, b] * g * inv, S[EMISSION + 2, b] * g * inv
        else:
            x = ux if is_sun else qx
            y = uy if is_sun else qy
            z = uz if is_sun else qz
            dist = far if is_sun else d2 * r
            att *= inv
            ex, ey, ez = S[RADIANCE, b] * att, S[RADIANCE + 1, b] * att, S[RADIANCE + 2, b] * att
        _light_ray(b, pts, x, y, z, dist, ex, ey, ez, rays)


@njit(cache=True, error_model="numpy", fastmath=True)
def _emitter_density(fx, fy, fz, two_sided, area_pdf, pick, t, dx, dy, dz):
    """The density (per solid angle) with which a light sample whose light was picked with
    probability `pick` draws direction d towards a point t away on an emitting triangle (face
    normal f, its AREA_PDF): pick x AREA_PDF x t^2 / cos_light; -1 where a one-sided triangle
    faces away (it sends no light that way)."""
    cl = -(fx * dx + fy * dy + fz * dz)
    cl = abs(cl) if two_sided > ZERO else cl
    if not cl > ZERO:
        return -ONE
    return pick * area_pdf * t * t / cl


@njit(cache=True, error_model="numpy", fastmath=True)
def _mis_weights(nb, S, pts, rays, acc, b0):
    """After _picked_rays, for multiple importance sampling (the reference path tracer's): each
    emitter's sample weighted by the power heuristic against cosine-weighted sampling of its
    direction, or with a GGX accumulator that has the lobe's share (acc[b0 + b, P_SPEC]: the
    reference's) against the BRDF's lobes (brdf.lobes_density). The light's density of that
    direction: _emitter_density, the point on the triangle found again from the direction and
    the triangle's plane. Its own loop, so that _picked_rays stays the branch-free one every
    pass runs."""
    px, py, pz, nx, ny, nz = pts[0], pts[1], pts[2], pts[3], pts[4], pts[5]
    dx, dy, dz, _, er, eg, eb = rays
    lobes = acc.shape[1] > P_SPEC
    for b in range(nb):
        if not S[IS_EMITTER, b] > ZERO or not S[INV_PROB, b] > ZERO:
            continue
        fx, fy, fz = S[FACE_NORMAL, b], S[FACE_NORMAL + 1, b], S[FACE_NORMAL + 2, b]
        # distance to the triangle's plane along the direction
        t = ((S[VERTEX, b] - px[b]) * fx + (S[VERTEX + 1, b] - py[b]) * fy + (S[VERTEX + 2, b] - pz[b]) * fz) / (
            fx * dx[b] + fy * dy[b] + fz * dz[b])
        p_light = _emitter_density(fx, fy, fz, S[TWO_SIDED, b], S[AREA_PDF, b], ONE / S[INV_PROB, b], t, dx[b], dy[b],
                                   dz[b])
        if p_light < ZERO:
            continue
        if lobes:
            i = b0 + b
            p_bsdf = lobes_density(acc[i, P_SPEC], acc[i, ALPHA], acc[i, VIEW], acc[i, VIEW + 1], acc[i, VIEW + 2],
                                   nx[b], ny[b], nz[b], dx[b], dy[b], dz[b])
        else:
            p_bsdf = max(nx[b] * dx[b] + ny[b] * dy[b] + nz[b] * dz[b], ZERO) * INV_PI
        w = mis_weight(p_light, p_bsdf)
        er[b], eg[b], eb[b] = er[b] * w, eg[b] * w, eb[b] * w


@njit(cache=True, error_model="numpy", fastmath=True)
def _sun_rays(keys, dim, nb, row, pts, far, rays):
    """_picked_rays where the scene's one light is a sun (row: its LIGHT_ROW): the cone sample
    alone, from the same two numbers (dimensions dim + 1 and dim + 2), without the point
    light's and the emitter's maths or the third number that only they use."""
    ax, ay, az, cos_ang = row[TO_SUN], row[TO_SUN + 1], row[TO_SUN + 2], row[SUN_COS]
    r0, r1, r2 = row[RADIANCE], row[RADIANCE + 1], row[RADIANCE + 2]
    for b in range(nb):
        key = keys[b]
        x, y, z = _sun(ax, ay, az, cos_ang, uniform(key, dim + 1), uniform(key, dim + 2))
        _light_ray(b, pts, x, y, z, far, r0, r1, r2, rays)


@njit(cache=True, error_model="numpy", nogil=True, fastmath=True)
def one_light_shadow_rays(G, g0, keys, dim, lights, far, weights, packed, tr, acc, mis=False):
    """One light per point of G (surface_soa rows), picked with probability ~ its estimated
    contribution there, sampled and divided by that probability (unbiased: accumulates to all
    lights); packed into packed (origin, direction, tmax, light, index) (or traced into acc if tr
    has a scene). lights: LightSet.kernel_args (analytic, emitters, guide, count).
    weights: (lights + SCRATCH_ROWS, BLOCK) scratch.
    Each step is a loop over the block's points: weights, draws, the pick, the picked light's
    row gathered, then the rays (branch-free: it vectorises)."""
    analytic, emitters, guide = lights[0], lights[1], lights[2]
    table = analytic_rows(analytic)
    na = table.shape[0]
    n_lights = weights.shape[0] - SCRATCH_ROWS
    w = weights[:n_lights]  # the running sums of the weights over the lights
    total, target, pick, u1, u2, u3 = (weights[n_lights], weights[n_lights + 1], weights[n_lights + 2],
                                       weights[n_lights + 3], weights[n_lights + 4], weights[n_lights + 5])
    S = np.empty((PICKED_ROWS, BLOCK), np.float32)
    single = n_lights == 1 and na == 1  # the pick is that light, with probability 1, at every point
    sun_only = single and table[0, IS_SUN] > ZERO  # and a sun: _sun_rays
    if single:  # its row once for every block: no weights, no pick, no gather
        for c in range(LIGHT_ROW):
            for b in range(BLOCK):
                S[c, b] = table[0, c]
        S[INV_PROB, :] = ONE  # probability 1 (where the light cannot contribute, _light_ray gives 0)
        S[IS_EMITTER, :] = ZERO
    blk = np.empty((7, BLOCK), np.float32)
    rays = step_rays(blk)
    u = (u1, u2, u3)
    trace = tracing(tr)
    m = 0
    n = keys.shape[0]
    for b0 in range(0, n, BLOCK):
        b1 = min(b0 + BLOCK, n)
        nb = b1 - b0
        pts, bkeys = step_points(G, g0 + b0, g0 + b1), keys[b0:b1]
        if sun_only:
            _sun_rays(bkeys, dim, nb, table[0], pts, far, rays)
        else:
            if single:
                _draw_samples(bkeys, dim, nb, u1, u2, u3)
            else:
                _light_weights(pts[0], pts[1], pts[2], pts[3], pts[4], pts[5], nb, guide, w, total)
                _draw_targets(bkeys, dim, nb, total, target, pick, u1, u2, u3)
                for k in range(n_lights - 1):  # the light picked: how many running sums lie below the target
                    for i in range(nb):
                        pick[i] += ONE if w[k, i] <= target[i] else ZERO
                _gather_picked(nb, na, pick, w, total, u1, table, emitters, S)
            _picked_rays(nb, S, u, pts, far, rays)
            if mis:
                _mis_weights(nb, S, pts, rays, acc, b0)
        m = _emit(G, g0, b0, nb, blk, m, far, packed, trace, acc, True)
    return m


@njit(cache=True, error_model="numpy", nogil=True, fastmath=True)
def emission_weights(P, N, D, prim, t, tri_light, tri_row, rows, guide, n_lights, Q, out):
    """out[i]: the power heuristic's weight of the emission found along D[i], drawn
    cosine-weighted about N[i] from P[i] (or with density Q[i] where Q is not empty: the
    reference's GGX lobes), on triangle prim[i] t[i] away, against one_light_shadow_rays drawing
    the same direction (its light's pick x _emitter_density; a triangle that is no light's is
    never drawn so: weight 1); 0 behind a one-sided emitter."""
    given = Q.shape[0] > 0
    n = P.shape[0]
    w = np.empty((max(n_lights, 1), BLOCK), np.float32)
    run = np.empty(BLOCK, np.float32)
    cols = np.empty((6, BLOCK), np.float32)
    for b0 in range(0, n, BLOCK):
        nb = min(BLOCK, n - b0)
        for i in range(nb):
            for a in range(3):
                cols[a, i], cols[3 + a, i] = P[b0 + i, a], N[b0 + i, a]
        _light_weights(cols[0], cols[1], cols[2], cols[3], cols[4], cols[5], nb, guide, w, run)
        for i in range(nb):
            j = b0 + i
            k, r = tri_light[prim[j]], tri_row[prim[j]]
            dx, dy, dz = D[j, 0], D[j, 1], D[j, 2]
            p_light = ZERO
            if k >= 0 and run[i] > ZERO:
                pick = (w[k, i] - (w[k - 1, i] if k > 0 else ZERO)) / run[i]
                p_light = _emitter_density(rows[r, FACE_NORMAL], rows[r, FACE_NORMAL + 1], rows[r, FACE_NORMAL + 2],
                                           rows[r, TWO_SIDED], rows[r, AREA_PDF], pick, t[j], dx, dy, dz)
            p_bsdf = Q[j] if given else max(N[j, 0] * dx + N[j, 1] * dy + N[j, 2] * dz, ZERO) * INV_PI
            out[j] = ZERO if p_light < ZERO else mis_weight(p_bsdf, p_light)
    return out


@njit(cache=True, error_model="numpy")
def no_rays():
    """Empty ray buffers, for generators that trace what they make (tr has a scene) and so never
    write rays out: (origin, direction, tmax, light, index)."""
    return (np.empty((0, 3), np.float32), np.empty((0, 3), np.float32), np.empty(0, np.float32),
            np.empty((0, 3), np.float32), np.empty(0, np.int32))


@njit(cache=True, error_model="numpy", nogil=True)
def _direct_start(n, tr, total):
    """direct_all's and direct_one's set-up: total zeroed (a GGX accumulator's view and alpha
    stay), and ray buffers for n points where tr has no scene (rtcore.no_trace: the rays are
    packed, then added unshadowed), else none (the generators trace what they make)."""
    total[:, :min(total.shape[1], SUM_EDVW + 3)] = ZERO
    if tr[0] != 0:
        return no_rays()
    return (np.empty((n, 3), np.float32), np.empty((n, 3), np.float32), np.empty(n, np.float32),
            np.empty((n, 3), np.float32), np.empty(n, np.int32))


@njit(cache=True, error_model="numpy", nogil=True)
def _traced_or_added(m, tr, total, packed, G, b0):
    """The rays a light's generator made: traced into total already (tr has a scene: m of them),
    or packed, and added here unshadowed (none traced, as shading._gather)."""
    if tr[0] != 0:
        return m
    d, e, idx = packed[1], packed[3], packed[4]
    add_unblocked(total, idx, d, e, np.zeros(m, np.bool_), m, G, b0)
    return 0


@njit(cache=True, error_model="numpy", nogil=True)
def direct_all(G, b0, keys, lights, dim0, far, tr, total):
    """Irradiance x cos from every light (one shadow ray each, dimensions dim0 + 3k) at points
    b0.. of G (keys: theirs), traced here and added into total (zeroed first); returns the rays
    traced. lights: LightSet.kernel_args. tr without a scene (rtcore.no_trace): unshadowed (the
    study's cheap GI), every ray's light added, none traced. A function of its own, not a branch
    of direct_one's: a kernel compiles only the light sampling that its options use (issue 44)."""
    analytic, emitters, guide, n_lights = lights
    packed = _direct_start(keys.shape[0], tr, total)
    start, rows, keep, alias = emitters
    cluster = (rows, keep, alias)
    count_analytic = analytic[0].shape[0]
    traced = 0
    for k in range(n_lights):
        dim = dim0 + 3 * k
        if k < count_analytic:
            m = analytic_shadow_rays(k, G, b0, keys, dim, analytic, far, packed, tr, total)
        else:
            j = k - count_analytic
            m = cluster_shadow_rays(start[j], start[j + 1], G, b0, keys, dim, cluster, packed, tr, total)
        traced += _traced_or_added(m, tr, total, packed, G, b0)
    return traced


@njit(cache=True, error_model="numpy", nogil=True)
def direct_one(G, b0, keys, lights, dim0, far, tr, total):
    """direct_all's light from one light per point, chosen by its contribution there
    (dimensions dim0..dim0+3; one_light_shadow_rays)."""
    n_lights = lights[3]
    packed = _direct_start(keys.shape[0], tr, total)
    if n_lights == 0:
        return 0
    weights = np.empty((n_lights + SCRATCH_ROWS, BLOCK), np.float32)
    m = one_light_shadow_rays(G, b0, keys, dim0, lights, far, weights, packed, tr, total, False)
    return _traced_or_added(m, tr, total, packed, G, b0)
