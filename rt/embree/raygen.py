"""Fused ray generators for the tracing threads: sample, build and pack the rays of a chunk,
in float32, writing only the rays worth tracing.

Points come as structure-of-arrays rows (`surface_soa`: px, py, pz, nx, ny, nz, gx, gy, gz),
columns g0 to g0 + len(keys) of G: a chunk of the G-buffer's rows (the unpack writes them) or
a whole Surface.soa(); `idx` counts from g0. Each generator walks the points in steps of RUN:
a loop over unit-stride rows computes the step's rays into a small block (it vectorises; over
(n, 3) arrays it does not), then a
short serial loop packs those that carry something: origins, directions, tmax and the light
they carry come out packed in front of the buffers, with `idx[j]` the point ray j belongs to,
and the count is returned. The packed buffers go to Embree as they are. Serial and GIL-free:
one call per chunk per thread.

Occlusion rays may instead be traced where they are made: given a tracing target `tr` with a
scene (rtcore.target: tr[0] not 0), a generator traces each ray of a step as the pack loop
would have written it and adds what gets through to `acc` (light: acc[i] += the light
carried; AO: acc[i, 0] += 1), so that sampling, tracing and gathering are one call without
the GIL, and no ray is written out (the whole-frame kernels; the reference path tracer's
chunks when `Tracer.inline_scene` allows it, else the caller traces the packed rays). The
rays, and so the images, are the same either way.

sin/cos come from a short polynomial (`sin_turns`), which vectorises where libm's does not and
is accurate to 4e-7, far below the sampling noise.
"""
from __future__ import annotations

import math

import numpy as np

from rt.embree import rtcore as embree
from rt.embree.brdf import ALPHA, P_SPEC, SUM_EDVW, VIEW, add_light, lobes_density
from rt.embree.jit import njit
from rt.embree.kernels import bits_float, float_bits, pixel_key, uniform
from rt.layout import (
    AREA_PDF,
    CONE_COS,
    CONE_SCALE,
    EDGE1,
    EDGE2,
    EMISSION,
    FACE_NORMAL,
    GX,
    GY,
    GZ,
    INV_PROB,
    IS_EMITTER,
    IS_SUN,
    LIGHT_ROW,
    NX,
    NY,
    NZ,
    PICKED_ROWS,
    POSITION,
    PX,
    PY,
    PZ,
    RADIANCE,
    SUN_COS,
    TO_SUN,
    TWO_SIDED,
    VERTEX,
)

F = np.float32
ZERO, HALF, ONE, TWO = F(0.0), F(0.5), F(1.0), F(2.0)
TAU = F(2.0 * math.pi)
S3, S5, S7, S9, S11 = F(-1 / 6), F(1 / 120), F(-1 / 5040), F(1 / 362880), F(-1 / 39916800)
TINY = F(1e-12)
INV_PI = F(1.0 / math.pi)


@njit(cache=True, error_model="numpy", fastmath=True)
def sin_turns(u):
    """sin(2 pi u) for u >= 0 (float32, branch-free)."""
    x = u - F(int(u + HALF))  # [-1/2, 1/2] turns
    x = min(x, HALF - x)  # fold onto [-1/4, 1/4]: sin(pi - t) = sin(t)
    x = max(x, -HALF - x)
    t = x * TAU
    t2 = t * t
    return t * (ONE + t2 * (S3 + t2 * (S5 + t2 * (S7 + t2 * (S9 + t2 * S11)))))


@njit(cache=True, error_model="numpy", fastmath=True)
def cos_turns(u):
    return sin_turns(u + F(0.25))


# Ray origins leave a surface by a nudge along its true normal that does not depend on the
# scene's size ("A Fast and Robust Method for Avoiding Self-Intersection", Ray Tracing Gems
# ch. 6): each coordinate moves by INT_SCALE x its normal component in units in the last place,
# so the nudge grows with the coordinate as its rounding error does; coordinates within ORIGIN
# of 0, whose ulps are tiny, move by FLOAT_SCALE x the normal component instead. The same rule in
# common.slang (offset_origin). Shadow rays stop SHADOW_SHORTEN of their length short of the light.
ORIGIN, FLOAT_SCALE, INT_SCALE = F(1.0 / 32.0), F(1.0 / 65536.0), F(256.0)
SHADOW_SHORTEN = F(1.0 / 4096.0)


@njit(cache=True, error_model="numpy")
def _nudge(p, n):
    p = F(p)
    if abs(p) < ORIGIN:
        return p + FLOAT_SCALE * F(n)
    of = np.int32(INT_SCALE * F(n))
    return bits_float(np.int32(float_bits(p) + (-of if p < ZERO else of)))


@njit(cache=True, error_model="numpy")
def mis_weight(p_this, p_other):
    """The power heuristic (Veach): the weight of a sample drawn with density p_this where
    another strategy would have drawn it with density p_other."""
    a, b = p_this * p_this, p_other * p_other
    return a / (a + b) if a + b > ZERO else ZERO


@njit(cache=True, error_model="numpy")
def offset_origin(px, py, pz, nx, ny, nz):
    """A ray origin off the surface at p on the side its true normal n points to (tnear stays 0)."""
    return _nudge(px, nx), _nudge(py, ny), _nudge(pz, nz)


@njit(cache=True, error_model="numpy")
def shadow_tmax(dist):
    """How far a shadow ray to a light dist away goes: short of the light (an emitter's own
    surface) by a fraction of its length, at any scale."""
    return dist * (ONE - SHADOW_SHORTEN)


@njit(cache=True, error_model="numpy", nogil=True)
def offset_origins(P, NG, out):
    """offset_origin over (n, 3) points and true normals (the NumPy steps' rays)."""
    for i in range(P.shape[0]):
        out[i, 0], out[i, 1], out[i, 2] = offset_origin(P[i, 0], P[i, 1], P[i, 2], NG[i, 0], NG[i, 1], NG[i, 2])
    return out


NOT_TRACED = np.zeros((0, 3), np.float32)  # `acc` for generators given no scene (tr[0] 0)
FRAME_BLOCK = 2048, 32768  # fewest and most points per work item of the whole-frame kernels (block_size)
BLOCKS_PER_WORKER = 8
TAIL_SHARE = 2  # block_bounds: the last blocks take at most 1 / (TAIL_SHARE x workers) of what is left
RUN = 256  # points per step: a vectorised loop fills the step's rays, a short serial one packs them
# a step's rays (`blk`, a column per point): direction, distance to the light, the light it
# carries (AO rays: CARRIED > 0 where the ray is kept)
DIR, DIST, CARRIED = 0, 3, 4


@njit(cache=True, error_model="numpy")
def _transpose3(A, x, y, z):
    for i in range(A.shape[0]):
        x[i], y[i], z[i] = A[i, 0], A[i, 1], A[i, 2]


@njit(cache=True, error_model="numpy", nogil=True)
def surface_soa(P, N, NG, out):
    """out (9, n): the rows px, py, pz, nx, ny, nz, gx, gy, gz of points given as (n, 3) arrays:
    what the generators read (unit-stride rows vectorise; strided (n, 3) reads do not)."""
    _transpose3(P, out[0], out[1], out[2])
    _transpose3(N, out[3], out[4], out[5])
    _transpose3(NG, out[6], out[7], out[8])


@njit(cache=True, error_model="numpy", fastmath=True)
def _pack(G, g0, b0, nb, blk, m, tmax_value, origin, direction, tmax, e, idx, light):
    """Append the step's rays that carry something, in order: origin offset_origin(p, ng), direction
    (blk's DIR rows), and the point's index; for light rays (`light`) tmax from the DIST row,
    stopping short of the light, and the light CARRIED, kept where it is not zero; for others
    tmax_value, kept where CARRIED > 0. Branch-free: every ray is written at
    slot m, and m moves on only past those kept. (The step loops leave the offset and tmax to
    this loop: fewer output rows let them vectorise.)"""
    for j in range(nb):
        i = b0 + j
        origin[m, 0], origin[m, 1], origin[m, 2] = offset_origin(G[PX, g0 + i], G[PY, g0 + i], G[PZ, g0 + i],
                                                                 G[GX, g0 + i], G[GY, g0 + i], G[GZ, g0 + i])
        direction[m, 0], direction[m, 1], direction[m, 2] = blk[DIR, j], blk[DIR + 1, j], blk[DIR + 2, j]
        idx[m] = i
        if light:
            tmax[m] = shadow_tmax(blk[DIST, j])
            ex, ey, ez = blk[CARRIED, j], blk[CARRIED + 1, j], blk[CARRIED + 2, j]
            e[m, 0], e[m, 1], e[m, 2] = ex, ey, ez
            m += max(ex, ey, ez) > ZERO
        else:
            tmax[m] = tmax_value
            m += blk[CARRIED, j] > ZERO
    return m


@njit(cache=True, error_model="numpy", fastmath=True)
def _trace_add(G, g0, b0, nb, blk, tmax_value, tr, buf, words, b, acc, light):
    """_pack's rays, traced one by one instead of written out; acc[point] gains what each ray
    that gets through carries (see _pack and the module notes). Returns how many were traced."""
    m = 0
    at = embree.log_reserve(tr, nb)  # the step's slots in tr's ray log (-1: not logging)
    for j in range(nb):
        slot = at + j if at >= 0 else at
        if light:
            ex, ey, ez = blk[CARRIED, j], blk[CARRIED + 1, j], blk[CARRIED + 2, j]
            if not max(ex, ey, ez) > ZERO:
                embree.log_put(tr, slot, -ONE, ZERO, ZERO, ZERO, ZERO, ZERO, ZERO, ZERO)
                continue
        elif not blk[CARRIED, j] > ZERO:
            embree.log_put(tr, slot, -ONE, ZERO, ZERO, ZERO, ZERO, ZERO, ZERO, ZERO)
            continue
        i = b0 + j
        ox, oy, oz = offset_origin(G[PX, g0 + i], G[PY, g0 + i], G[PZ, g0 + i], G[GX, g0 + i], G[GY, g0 + i],
                                   G[GZ, g0 + i])
        t = shadow_tmax(blk[DIST, j]) if light else tmax_value
        m += 1
        if embree.trace_occluded(tr, slot, buf, words, b, ox, oy, oz, blk[DIR, j], blk[DIR + 1, j], blk[DIR + 2, j], t):
            continue
        if light:
            add_light(acc, i, ex, ey, ez, G[NX, g0 + i], G[NY, g0 + i], G[NZ, g0 + i], blk[DIR, j], blk[DIR + 1, j],
                      blk[DIR + 2, j])
        else:
            acc[i, 0] += ONE
    return m


@njit(cache=True, error_model="numpy", fastmath=True)
def _emit(G, g0, b0, nb, blk, m, tmax_value, origin, direction, tmax, e, idx, tr, buf, words, b, acc, light):
    """A step's rays (blk), traced into acc if tr has a scene (_trace_add), else packed after the
    m already packed (_pack); returns the new count."""
    if tr[0]:
        return m + _trace_add(G, g0, b0, nb, blk, tmax_value, tr, buf, words, b, acc, light)
    return _pack(G, g0, b0, nb, blk, m, tmax_value, origin, direction, tmax, e, idx, light)


@njit(cache=True, error_model="numpy", fastmath=True)
def about(nx, ny, nz, x, y, z):
    """(x, y, z) in the orthonormal basis about n (Duff et al. 2017)."""
    sign = ONE if nz >= ZERO else -ONE
    a = -ONE / (sign + nz)
    b = nx * ny * a
    return ((ONE + sign * nx * nx * a) * x + b * y + nx * z,
            sign * b * x + (sign + ny * ny * a) * y + ny * z,
            -sign * nx * x - ny * y + nz * z)


@njit(cache=True, error_model="numpy", fastmath=True)
def cosine_about(nx, ny, nz, u0, u1):
    """A cosine-weighted direction about unit n from the numbers u0, u1 (common.slang's
    cosine_direction)."""
    r = np.sqrt(u0)
    return about(nx, ny, nz, r * cos_turns(u1), r * sin_turns(u1), np.sqrt(max(ZERO, ONE - u0)))


@njit(cache=True, error_model="numpy", fastmath=True)
def _hemisphere_step(nx, ny, nz, gx, gy, gz, keys, dim, dx, dy, dz, keep, nb):
    for j in range(nb):
        key = keys[j]
        x, y, z = cosine_about(nx[j], ny[j], nz[j], uniform(key, dim), uniform(key, dim + 1))
        dx[j], dy[j], dz[j] = x, y, z
        keep[j] = gx[j] * x + gy[j] * y + gz[j] * z


@njit(cache=True, error_model="numpy", nogil=True, fastmath=True)
def hemisphere_live(G, g0, keys, dim, tmax_value, origin, direction, tmax, idx, tr, acc):
    """Cosine-weighted rays about the shading normals of points G (surface_soa rows); packs
    those above the true surface (or, if tr has a scene, traces them and counts in acc those
    that escape). Returns the count."""
    n = keys.shape[0]
    blk = np.empty((7, RUN), np.float32)
    buf, b = embree.ray_buffer()
    words = buf.view(np.uint32)
    m = 0
    for b0 in range(0, n, RUN):
        b1 = min(b0 + RUN, n)
        c0, c1 = g0 + b0, g0 + b1  # columns of G
        _hemisphere_step(G[NX, c0:c1], G[NY, c0:c1], G[NZ, c0:c1], G[GX, c0:c1], G[GY, c0:c1], G[GZ, c0:c1],
                         keys[b0:b1], dim, blk[0], blk[1], blk[2], blk[4], b1 - b0)
        m = _emit(G, g0, b0, b1 - b0, blk, m, tmax_value, origin, direction, tmax, origin, idx, tr, buf, words, b,
                  acc, False)
    return m


@njit(cache=True, error_model="numpy", nogil=True, fastmath=True)
def cosine_dirs(N, keys, dim, out):
    """Cosine-weighted directions about N (not packed: some may point below the true surface)."""
    for i in range(N.shape[0]):
        out[i, 0], out[i, 1], out[i, 2] = cosine_about(N[i, 0], N[i, 1], N[i, 2], uniform(keys[i], dim),
                                                       uniform(keys[i], dim + 1))


@njit(cache=True, error_model="numpy", fastmath=True)
def _light_ray(j, nx, ny, nz, gx, gy, gz, x, y, z, dist, ex, ey, ez, dx, dy, dz, dd, er, eg, eb):
    """Step slot j: a shadow ray towards (x, y, z) at distance dist, with its unshadowed
    irradiance x cos: zero where the light is below the shading or the true surface."""
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
def _analytic_step(k, px, py, pz, nx, ny, nz, gx, gy, gz, keys, dim, analytic, far, dx, dy, dz, dd, er, eg, eb, nb):
    """One loop per light type, so each stays short and branch-free; the light's parameters are
    read into locals first (loads from the light arrays inside the loop would have to be
    repeated, as the compiler cannot rule out that the stores change them, and do not vectorise)."""
    kind, lpos, ldir, lrad, cos_out, spot_scale, cos_ang, lum = analytic
    r0, r1, r2 = lrad[k, 0], lrad[k, 1], lrad[k, 2]
    if kind[k] == 2:
        ax, ay, az, ca = -ldir[k, 0], -ldir[k, 1], -ldir[k, 2], cos_ang[k]
        for j in range(nb):
            x, y, z = _sun(ax, ay, az, ca, uniform(keys[j], dim), uniform(keys[j], dim + 1))
            _light_ray(j, nx, ny, nz, gx, gy, gz, x, y, z, far, r0, r1, r2, dx, dy, dz, dd, er, eg, eb)
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
        _light_ray(j, nx, ny, nz, gx, gy, gz, x, y, z, d2 * inv, r0 * att, r1 * att, r2 * att, dx, dy, dz, dd, er, eg,
                   eb)


@njit(cache=True, error_model="numpy", nogil=True, fastmath=True)
def analytic_shadow_rays(k, G, g0, keys, dim, analytic, far, origin, direction, tmax, e, idx, tr, acc):
    """Shadow rays towards analytic light k from every point of G (surface_soa rows), packed
    (or traced into acc if tr has a scene); returns the count."""
    n = keys.shape[0]
    blk = np.empty((7, RUN), np.float32)
    buf, b = embree.ray_buffer()
    words = buf.view(np.uint32)
    m = 0
    for b0 in range(0, n, RUN):
        b1 = min(b0 + RUN, n)
        c0, c1 = g0 + b0, g0 + b1  # columns of G
        _analytic_step(k, G[PX, c0:c1], G[PY, c0:c1], G[PZ, c0:c1], G[NX, c0:c1], G[NY, c0:c1], G[NZ, c0:c1],
                       G[GX, c0:c1], G[GY, c0:c1], G[GZ, c0:c1], keys[b0:b1], dim, analytic, far,
                       blk[0], blk[1], blk[2], blk[3], blk[4], blk[5], blk[6], b1 - b0)
        m = _emit(G, g0, b0, b1 - b0, blk, m, far, origin, direction, tmax, e, idx, tr, buf, words, b, acc, True)
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
def _cluster_step(lo, hi, px, py, pz, nx, ny, nz, gx, gy, gz, keys, dim, rows, keep, alias, dx, dy, dz, dd, er, eg,
                  eb, U, S, nb):
    """Three loops: each point's numbers (vectorises: the hash is integer arithmetic), the
    triangle it picks (alias method: dependent loads) with its row copied into the columns of
    S, then the rays to points on those triangles, from unit-stride rows (vectorises; reading
    rows[t] there would keep it scalar)."""
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
        _light_ray(j, nx, ny, nz, gx, gy, gz, x, y, z, d2 * inv * F(1.0 - 1e-4), S[EMISSION, j] * g,
                   S[EMISSION + 1, j] * g, S[EMISSION + 2, j] * g, dx, dy, dz, dd, er, eg, eb)


@njit(cache=True, error_model="numpy", nogil=True, fastmath=True)
def cluster_shadow_rays(lo, hi, G, g0, keys, dim, rows, keep, alias, origin, direction, tmax, e, idx, tr,
                        acc):
    """Shadow rays towards one emissive cluster (emitter rows lo:hi) from every point of G,
    packed (or traced into acc if tr has a scene)."""
    n = keys.shape[0]
    blk = np.empty((7, RUN), np.float32)
    U, S = np.empty((3, RUN), np.float32), np.empty((LIGHT_ROW, RUN), np.float32)
    buf, b = embree.ray_buffer()
    words = buf.view(np.uint32)
    m = 0
    for b0 in range(0, n, RUN):
        b1 = min(b0 + RUN, n)
        c0, c1 = g0 + b0, g0 + b1  # columns of G
        _cluster_step(lo, hi, G[PX, c0:c1], G[PY, c0:c1], G[PZ, c0:c1], G[NX, c0:c1], G[NY, c0:c1], G[NZ, c0:c1],
                      G[GX, c0:c1], G[GY, c0:c1], G[GZ, c0:c1], keys[b0:b1], dim, rows, keep, alias,
                      blk[0], blk[1], blk[2], blk[3], blk[4], blk[5], blk[6], U, S, b1 - b0)
        m = _emit(G, g0, b0, b1 - b0, blk, m, ZERO, origin, direction, tmax, e, idx, tr, buf, words, b, acc, True)
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
def _picked_rays(nb, S, u1, u2, u3, px, py, pz, nx, ny, nz, gx, gy, gz, far, dx, dy, dz, dd, er, eg, eb):
    """The shadow ray of every point towards the light it picked (rows S, _gather_picked),
    divided by the pick's probability: one branch-free loop over unit-stride rows that
    computes a sun's cone sample (_sun), a point or spot light's direction (its distance and
    glTF's squared linear ramp, as _analytic_step) and a point on an emitting triangle
    (Le x cos_light / d^2 / pdf_area, as _cluster_step), and keeps the one that applies."""
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
        _light_ray(b, nx, ny, nz, gx, gy, gz, x, y, z, dist, ex, ey, ez, dx, dy, dz, dd, er, eg, eb)


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
def _mis_weights(nb, S, px, py, pz, nx, ny, nz, dx, dy, dz, er, eg, eb, acc, b0):
    """After _picked_rays, for multiple importance sampling (the reference path tracer's): each
    emitter's sample weighted by the power heuristic against cosine-weighted sampling of its
    direction, or with a GGX accumulator that has the lobe's share (acc[b0 + b, P_SPEC]: the
    reference's) against the BRDF's lobes (brdf.lobes_density). The light's density of that
    direction: _emitter_density, the point on the triangle found again from the direction and
    the triangle's plane. Its own loop, so that _picked_rays stays the branch-free one every
    pass runs."""
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
def _sun_rays(keys, dim, nb, row, nx, ny, nz, gx, gy, gz, far, dx, dy, dz, dd, er, eg, eb):
    """_picked_rays where the scene's one light is a sun (row: its LIGHT_ROW): the cone sample
    alone, from the same two numbers (dimensions dim + 1 and dim + 2), without the point
    light's and the emitter's maths or the third number that only they use."""
    ax, ay, az, cos_ang = row[TO_SUN], row[TO_SUN + 1], row[TO_SUN + 2], row[SUN_COS]
    r0, r1, r2 = row[RADIANCE], row[RADIANCE + 1], row[RADIANCE + 2]
    for b in range(nb):
        key = keys[b]
        x, y, z = _sun(ax, ay, az, cos_ang, uniform(key, dim + 1), uniform(key, dim + 2))
        _light_ray(b, nx, ny, nz, gx, gy, gz, x, y, z, far, r0, r1, r2, dx, dy, dz, dd, er, eg, eb)


@njit(cache=True, error_model="numpy", nogil=True, fastmath=True)
def one_light_shadow_rays(G, g0, keys, dim, analytic, emitters, guide, far, weights, origin, direction, tmax,
                          e, idx, tr, acc, mis=False):
    """One light per point of G (surface_soa rows), picked with probability ~ its estimated
    contribution there, sampled and divided by that probability (unbiased: accumulates to all
    lights); packed (or traced into acc if tr has a scene). weights: (lights + SCRATCH_ROWS, BLOCK) scratch.
    Each step is a loop over the block's points: weights, draws, the pick, the picked light's
    row gathered, then the rays (branch-free: it vectorises)."""
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
    dx, dy, dz, dd, er, eg, eb = blk[0], blk[1], blk[2], blk[3], blk[4], blk[5], blk[6]
    buf, rb = embree.ray_buffer()
    words = buf.view(np.uint32)
    m = 0
    n = keys.shape[0]
    for b0 in range(0, n, BLOCK):
        b1 = min(b0 + BLOCK, n)
        c0, c1 = g0 + b0, g0 + b1  # columns of G
        nb = b1 - b0
        px, py, pz, nx, ny, nz = G[PX, c0:c1], G[PY, c0:c1], G[PZ, c0:c1], G[NX, c0:c1], G[NY, c0:c1], G[NZ, c0:c1]
        gx, gy, gz, bkeys = G[GX, c0:c1], G[GY, c0:c1], G[GZ, c0:c1], keys[b0:b1]
        if sun_only:
            _sun_rays(bkeys, dim, nb, table[0], nx, ny, nz, gx, gy, gz, far, dx, dy, dz, dd, er, eg, eb)
        else:
            if single:
                _draw_samples(bkeys, dim, nb, u1, u2, u3)
            else:
                _light_weights(px, py, pz, nx, ny, nz, nb, guide, w, total)
                _draw_targets(bkeys, dim, nb, total, target, pick, u1, u2, u3)
                for k in range(n_lights - 1):  # the light picked: how many running sums lie below the target
                    for i in range(nb):
                        pick[i] += ONE if w[k, i] <= target[i] else ZERO
                _gather_picked(nb, na, pick, w, total, u1, table, emitters, S)
            _picked_rays(nb, S, u1, u2, u3, px, py, pz, nx, ny, nz, gx, gy, gz, far, dx, dy, dz, dd, er, eg, eb)
            if mis:
                _mis_weights(nb, S, px, py, pz, nx, ny, nz, dx, dy, dz, er, eg, eb, acc, b0)
        m = _emit(G, g0, b0, nb, blk, m, far, origin, direction, tmax, e, idx, tr, buf, words, rb, acc, True)
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


@njit(cache=True, error_model="numpy", nogil=True)
def add_unblocked(total, idx, d, e, blocked, m, G, g0):
    """total[idx[j]] += e[j] arriving along d[j] (brdf.add_light; G, g0: the points' rows) for
    the first m packed rays that were not blocked."""
    for j in range(m):
        if not blocked[j]:
            i = idx[j]
            add_light(total, i, e[j, 0], e[j, 1], e[j, 2], G[NX, g0 + i], G[NY, g0 + i], G[NZ, g0 + i], d[j, 0],
                      d[j, 1], d[j, 2])


@njit(cache=True, error_model="numpy")
def block_size(n, workers):
    """Points per work item of the whole-frame kernels: n / (BLOCKS_PER_WORKER x workers),
    within FRAME_BLOCK's bounds. A pass's steps run a block at a time, and larger blocks keep
    each step's data (the BVH while tracing, mesh rows while shading) in the cache longer."""
    return min(max(n // (workers * BLOCKS_PER_WORKER), FRAME_BLOCK[0]), FRAME_BLOCK[1])


@njit(cache=True, error_model="numpy")
def block_bounds(n, workers):
    """The whole-frame kernels' work items: points bounds[i]..bounds[i + 1]. Blocks of
    block_size, shrinking towards the end of the frame (each at most the points left over
    TAIL_SHARE x workers, and at least FRAME_BLOCK[0]), so that the workers finish together:
    with equal blocks, one worker could take the last block just as the others ran out of work,
    and they idled for up to a block's time."""
    size = block_size(n, workers)
    tail = TAIL_SHARE * workers
    bounds = np.empty(n // FRAME_BLOCK[0] + 2, np.int64)
    bounds[0] = 0
    count, b = 0, 0
    while b < n:
        # one worker: nobody to wait for, blocks of block_size to the end
        step = size if workers == 1 else min(size, max((n - b) // tail, FRAME_BLOCK[0]))
        b = min(b + step, n)
        count += 1
        bounds[count] = b
    return bounds[:count + 1]


@njit(cache=True, error_model="numpy")
def block_keys(pix, b0, b1, base):
    """The keys of a whole-frame kernel's block of points (pixels pix[b0:b1]), made by the
    worker that uses them (base: RtFrame.key_base): a pass over every pixel before the frame,
    and the keys' round trip through memory, saved."""
    keys = np.empty(b1 - b0, np.uint64)
    for j in range(b1 - b0):
        keys[j] = pixel_key(pix[b0 + j], base)
    return keys


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
def _traced_or_added(m, tr, total, idx, d, e, G, b0):
    """The rays a light's generator made: traced into total already (tr has a scene: m of them),
    or packed, and added here unshadowed (none traced, as shading._gather)."""
    if tr[0] != 0:
        return m
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
    o, d, t, e, idx = _direct_start(keys.shape[0], tr, total)
    start, rows, keep, alias = emitters
    count_analytic = analytic[0].shape[0]
    traced = 0
    for k in range(n_lights):
        dim = dim0 + 3 * k
        if k < count_analytic:
            m = analytic_shadow_rays(k, G, b0, keys, dim, analytic, far, o, d, t, e, idx, tr, total)
        else:
            j = k - count_analytic
            m = cluster_shadow_rays(start[j], start[j + 1], G, b0, keys, dim, rows, keep, alias, o, d, t, e, idx,
                                    tr, total)
        traced += _traced_or_added(m, tr, total, idx, d, e, G, b0)
    return traced


@njit(cache=True, error_model="numpy", nogil=True)
def direct_one(G, b0, keys, lights, dim0, far, tr, total):
    """direct_all's light from one light per point, chosen by its contribution there
    (dimensions dim0..dim0+3; one_light_shadow_rays)."""
    analytic, emitters, guide, n_lights = lights
    o, d, t, e, idx = _direct_start(keys.shape[0], tr, total)
    if n_lights == 0:
        return 0
    weights = np.empty((n_lights + SCRATCH_ROWS, BLOCK), np.float32)
    m = one_light_shadow_rays(G, b0, keys, dim0, analytic, emitters, guide, far, weights, o, d, t, e, idx, tr,
                              total, False)
    return _traced_or_added(m, tr, total, idx, d, e, G, b0)
