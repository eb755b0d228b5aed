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
from rt.embree.brdf import add_light
from rt.embree.jit import njit
from rt.embree.kernels import bits_float, float_bits, uniform
from rt.layout import (
    GX,
    GY,
    GZ,
    NX,
    NY,
    NZ,
    PX,
    PY,
    PZ,
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


@njit(cache=True, error_model="numpy")
def tracing(tr):
    """A generator's tracing record: the target tr (rtcore.target) with a packet of rays (rtcore.OCCLUDE_PACKET) of
    its own (rtcore.packet) and which ray of a step each of its lanes holds."""
    return tr, embree.packet(embree.OCCLUDE_PACKET), np.empty(embree.OCCLUDE_PACKET, np.int64)


@njit(cache=True, error_model="numpy")
def step_points(G, c0, c1):
    """Columns c0:c1 of G (surface_soa rows) as one record: (px, py, pz, nx, ny, nz, gx, gy, gz)."""
    return (G[PX, c0:c1], G[PY, c0:c1], G[PZ, c0:c1], G[NX, c0:c1], G[NY, c0:c1], G[NZ, c0:c1],
            G[GX, c0:c1], G[GY, c0:c1], G[GZ, c0:c1])


@njit(cache=True, error_model="numpy")
def step_rays(blk):
    """A step's ray rows as one record: (dx, dy, dz, dist, er, eg, eb) (DIR, DIST, CARRIED)."""
    return blk[0], blk[1], blk[2], blk[3], blk[4], blk[5], blk[6]


@njit(cache=True, error_model="numpy")
def without_light(packed):
    """Packed-ray buffers (origin, direction, tmax, index) as _pack takes them for rays that
    carry no light: the origin buffer stands in for the light buffer, which _pack never writes."""
    origin, direction, tmax, idx = packed
    return origin, direction, tmax, origin, idx


@njit(cache=True, error_model="numpy", fastmath=True)
def _pack(G, g0, b0, nb, blk, m, tmax_value, packed, light):
    """Append the step's rays that carry something, in order: origin offset_origin(p, ng), direction
    (blk's DIR rows), and the point's index; for light rays (`light`) tmax from the DIST row,
    stopping short of the light, and the light CARRIED, kept where it is not zero; for others
    tmax_value, kept where CARRIED > 0. Branch-free: every ray is written at
    slot m, and m moves on only past those kept. (The step loops leave the offset and tmax to
    this loop: fewer output rows let them vectorise.) packed: the buffers (origin, direction,
    tmax, light, index) the rays go to."""
    origin, direction, tmax, e, idx = packed
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
def _trace_add(G, g0, b0, nb, blk, tmax_value, trace, acc, light):
    """_pack's rays, traced instead of written out, rtcore.OCCLUDE_PACKET to a packet (occluded_packet); acc[point]
    gains what each ray that gets through carries (see _pack and the module notes). trace:
    tracing(tr)'s record. Returns how many were traced."""
    tr, pk, lane_of = trace
    m = 0
    lanes = 0
    at = embree.log_reserve(tr, nb)  # the step's slots in tr's ray log (-1: not logging)
    for j in range(nb):
        slot = at + j if at >= 0 else at
        if light:
            if not max(blk[CARRIED, j], blk[CARRIED + 1, j], blk[CARRIED + 2, j]) > ZERO:
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
        embree.log_put(tr, slot, ZERO, ox, oy, oz, blk[DIR, j], blk[DIR + 1, j], blk[DIR + 2, j], t)
        embree.set_lane(pk[0], pk[1], embree.OCCLUDE_PACKET, lanes, ox, oy, oz, blk[DIR, j], blk[DIR + 1, j],
                        blk[DIR + 2, j], t)
        lane_of[lanes] = j
        lanes += 1
        if lanes == embree.OCCLUDE_PACKET:
            _add_unblocked(G, g0, b0, blk, tr[0], pk, lane_of, lanes, acc, light)
            lanes = 0
    if lanes:
        _add_unblocked(G, g0, b0, blk, tr[0], pk, lane_of, lanes, acc, light)
    return m


@njit(cache=True, error_model="numpy", fastmath=True)
def _add_unblocked(G, g0, b0, blk, scene, pk, lane_of, lanes, acc, light):
    """Trace a packet of _trace_add's rays (lane k: the step's ray lane_of[k]); acc[point] gains
    what each ray that gets through carries."""
    embree.occluded_packet(scene, pk, lanes)
    for k in range(lanes):
        if embree.blocked_lane(pk, k):
            continue
        j = lane_of[k]
        i = b0 + j
        if light:
            add_light(acc, i, blk[CARRIED, j], blk[CARRIED + 1, j], blk[CARRIED + 2, j], G[NX, g0 + i],
                      G[NY, g0 + i], G[NZ, g0 + i], blk[DIR, j], blk[DIR + 1, j], blk[DIR + 2, j])
        else:
            acc[i, 0] += ONE


@njit(cache=True, error_model="numpy", fastmath=True)
def _emit(G, g0, b0, nb, blk, m, tmax_value, packed, trace, acc, light):
    """A step's rays (blk), traced into acc if the target has a scene (_trace_add), else packed
    into `packed` after the m already there (_pack); returns the new count."""
    if trace[0][0]:
        return m + _trace_add(G, g0, b0, nb, blk, tmax_value, trace, acc, light)
    return _pack(G, g0, b0, nb, blk, m, tmax_value, packed, light)


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
def _hemisphere_step(pts, keys, dim, rays, nb):
    """Cosine-weighted directions about the step's shading normals into rays' DIR rows, and
    their cosine with the true normal (> 0: kept) into CARRIED."""
    nx, ny, nz, gx, gy, gz = pts[3], pts[4], pts[5], pts[6], pts[7], pts[8]
    dx, dy, dz, keep = rays[0], rays[1], rays[2], rays[4]
    for j in range(nb):
        key = keys[j]
        x, y, z = cosine_about(nx[j], ny[j], nz[j], uniform(key, dim), uniform(key, dim + 1))
        dx[j], dy[j], dz[j] = x, y, z
        keep[j] = gx[j] * x + gy[j] * y + gz[j] * z


@njit(cache=True, error_model="numpy", nogil=True, fastmath=True)
def hemisphere_live(G, g0, keys, dim, tmax_value, packed, tr, acc):
    """Cosine-weighted rays about the shading normals of points G (surface_soa rows); packs
    those above the true surface into packed (origin, direction, tmax, index) (or, if tr has a
    scene, traces them and counts in acc those that escape). Returns the count."""
    packed = without_light(packed)
    n = keys.shape[0]
    blk = np.empty((7, RUN), np.float32)
    rays = step_rays(blk)
    trace = tracing(tr)
    m = 0
    for b0 in range(0, n, RUN):
        b1 = min(b0 + RUN, n)
        _hemisphere_step(step_points(G, g0 + b0, g0 + b1), keys[b0:b1], dim, rays, b1 - b0)
        m = _emit(G, g0, b0, b1 - b0, blk, m, tmax_value, packed, trace, acc, False)
    return m


@njit(cache=True, error_model="numpy", nogil=True, fastmath=True)
def cosine_dirs(N, keys, dim, out):
    """Cosine-weighted directions about N (not packed: some may point below the true surface)."""
    for i in range(N.shape[0]):
        out[i, 0], out[i, 1], out[i, 2] = cosine_about(N[i, 0], N[i, 1], N[i, 2], uniform(keys[i], dim),
                                                       uniform(keys[i], dim + 1))


@njit(cache=True, error_model="numpy", nogil=True)
def add_unblocked(total, idx, d, e, blocked, m, G, g0):
    """total[idx[j]] += e[j] arriving along d[j] (brdf.add_light; G, g0: the points' rows) for
    the first m packed rays that were not blocked."""
    for j in range(m):
        if not blocked[j]:
            i = idx[j]
            add_light(total, i, e[j, 0], e[j, 1], e[j, 2], G[NX, g0 + i], G[NY, g0 + i], G[NZ, g0 + i], d[j, 0],
                      d[j, 1], d[j, 2])


