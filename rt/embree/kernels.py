"""Compiled per-point kernels (numba, parallel over points) for light sampling, ray set-up
and hit shading: the work between Embree calls. NumPy versions of the same maths would
allocate a temporary per operation; these loop once per point and write into flat arrays.

Conventions are those of rt/embree/shading.py (which documents them); the kernels are its engine.
"""
from __future__ import annotations

import math
import threading
import types
from contextlib import contextmanager

import numba
import numpy as np
from llvmlite import ir
from numba import prange
from numba.core import cgutils
from numba.core import types as nbtypes
from numba.extending import intrinsic

from rt.embree import textures
from rt.embree.jit import njit
from rt.layout import GX, GY, GZ, NX, NY, NZ, PX, PY, PZ
from rt.mesh import LAYER_BASE, LAYER_EMISSION, LAYER_NORMAL, LAYER_ORM

TWO_PI = 2.0 * math.pi
GOLDEN = np.uint64(0x9E3779B97F4A7C15)
M1 = np.uint64(0xBF58476D1CE4E5B9)
M2 = np.uint64(0x94D049BB133111EB)
# A hit found at o + t d (unit d), or from a camera ray and a depth, is off its surface by up to a
# few ulps of each coordinate's terms |o_i| + |t d_i| (PBRT 4, 6.8): each is lifted HIT_ERROR x
# sum_i |n_i| (|o_i| + |t d_i|) along its true normal n when made, so that the nudge of the rays
# leaving it (raygen.offset_origin) starts on the right side. Per coordinate, not the largest:
# a floor seen 10 km away along it errs by ulps of the camera's height, not of 10 km.
HIT_ERROR = np.float32(2.0**-20)


@njit(cache=True, error_model="numpy")
def hit_lift(ox, oy, oz, tx, ty, tz, nx, ny, nz):
    """How far a hit o + t (t: the ray's vector to it) is lifted along its true normal n (HIT_ERROR)."""
    return (abs(nx) * (abs(ox) + abs(tx)) + abs(ny) * (abs(oy) + abs(ty)) + abs(nz) * (abs(oz) + abs(tz))) * HIT_ERROR


@intrinsic
def prefetch_row(typingctx, array, row):
    """Ask the CPU to start loading row `row` of `array` into the cache (x86 PREFETCHT0; no
    fault, no result). Incoherent hits read mesh rows at random: fetched a few hits ahead, the
    misses overlap instead of stalling one after another."""
    if not isinstance(array, nbtypes.Array) or not isinstance(row, nbtypes.Integer):
        return None

    def codegen(context, builder, signature, args):
        aty = signature.args[0]
        ary = context.make_array(aty)(context, builder, args[0])
        zero = context.get_constant(nbtypes.intp, 0)
        index = context.cast(builder, args[1], signature.args[1], nbtypes.intp)
        ptr = cgutils.get_item_pointer(context, builder, aty, ary, [index] + [zero] * (aty.ndim - 1),
                                       wraparound=False)
        i8p, i32 = ir.IntType(8).as_pointer(), ir.IntType(32)
        fn = cgutils.get_or_insert_function(builder.module, ir.FunctionType(ir.VoidType(), [i8p, i32, i32, i32]),
                                            "llvm.prefetch.p0i8")
        builder.call(fn, [builder.bitcast(ptr, i8p), ir.Constant(i32, 0), ir.Constant(i32, 3), ir.Constant(i32, 1)])
        return context.get_dummy_value()

    return nbtypes.void(array, row), codegen


@intrinsic
def float_bits(typingctx, x):
    """The bits of a float32 as an int32 (C++'s bit_cast): what an offset in ulps adds to."""
    if x != nbtypes.float32:
        return None

    def codegen(context, builder, signature, args):
        return builder.bitcast(args[0], ir.IntType(32))

    return nbtypes.int32(nbtypes.float32), codegen


@intrinsic
def bits_float(typingctx, i):
    """An int32's bits as a float32 (float_bits' inverse)."""
    if i != nbtypes.int32:
        return None

    def codegen(context, builder, signature, args):
        return builder.bitcast(args[0], ir.FloatType())

    return nbtypes.float32(nbtypes.int32), codegen


@intrinsic
def take_many(typingctx, counter, n):
    """counter[0] += n atomically, returning the value before: a run of n slots of a shared
    array for the calling thread alone (LLVM atomicrmw)."""
    if not isinstance(counter, nbtypes.Array) or counter.dtype != nbtypes.int64:
        return None

    def codegen(context, builder, signature, args):
        aty = signature.args[0]
        ary = context.make_array(aty)(context, builder, args[0])
        zero = context.get_constant(nbtypes.intp, 0)
        ptr = cgutils.get_item_pointer(context, builder, aty, ary, [zero] * aty.ndim, wraparound=False)
        count = context.cast(builder, args[1], signature.args[1], nbtypes.int64)
        return builder.atomic_rmw("add", ptr, count, "monotonic")

    return nbtypes.int64(counter, n), codegen


@njit(cache=True, error_model="numpy")
def take_next(counter):
    """counter[0] += 1 atomically, returning the value before: how the threads of a parallel
    kernel share out work items, each taking the next one when it is free."""
    return take_many(counter, np.int64(1))


@njit(cache=True, error_model="numpy")
def next_block(counter, bounds):
    """The next block of points (b0, b1) for a whole-frame kernel's worker (bounds:
    blocks.block_bounds); b0 >= n when all are taken. Workers take blocks in order as each becomes free
    (counter: a shared int64 array of one, zeroed), so a worker that drew cheap sky takes more
    and all finish together; the blocks being traced at one time are neighbours, which share the
    BVH's nodes in the cache. (Blocks dealt out in advance, every workers-th to each, left
    threads idle at the end of a frame whenever their share happened to cost more.)"""
    i = take_next(counter)
    last = bounds.shape[0] - 1
    if i >= last:
        return bounds[last], bounds[last]
    return bounds[i], bounds[i + 1]


AHEAD = 8  # hits whose mesh rows shade_hits asks for ahead of the one it shades (incoherent hits
# miss the cache on their mesh rows; 4 and 16 ahead gained less: report/HISTORY.md)


@njit(cache=True, error_model="numpy")
def mix64(x):
    """splitmix64 finaliser."""
    x = (x ^ (x >> np.uint64(30))) * M1
    x = (x ^ (x >> np.uint64(27))) * M2
    return x ^ (x >> np.uint64(31))


@njit(cache=True, error_model="numpy")
def uniform(key, dim):
    """The uniform number [0,1) of one pixel's key in one dimension."""
    h = mix64(key + (np.uint64(dim) + np.uint64(1)) * GOLDEN)
    return np.float32(h >> np.uint64(40)) * np.float32(1.0 / 16777216.0)


@njit(cache=True, error_model="numpy")
def pixel_key(pixel, base):
    """A pixel's generator key: a hash of its id and the frame's base key (sampling.key_base)."""
    return mix64(np.uint64(pixel) * GOLDEN + base)


@njit(cache=True, error_model="numpy", parallel=True)
def pixel_keys(pixels, base, out):
    """Each pixel's generator key (pixel_key)."""
    for i in prange(pixels.shape[0]):
        out[i] = pixel_key(pixels[i], base)


@njit(cache=True, error_model="numpy", parallel=True, fastmath=True)
def uniforms(keys, dim0, k, out):
    for i in prange(keys.shape[0]):
        for j in range(k):
            out[i, j] = uniform(keys[i], dim0 + j)


SHADE_RUN = 256  # hits per run of _shade_run


# numba's own njit, inlined into shade_hits' loops at numba IR level (inline="always"): they then
# compile as the one loop they were, not as calls through rt/embree/jit.py's linked twins
@numba.njit(cache=True, error_model="numpy", fastmath=True, inline="always")
def _shade_run(k0, k1, n, sel, hits, rays, mesh, out):
    """shade_hits for hits k0..k1 of n. A function of its own, given the records whole: in a
    parallel kernel, numba (0.68) loses writes to arrays taken out of a tuple before the loop
    (tests/test_jit.py)."""
    prim, bu, bv, t = hits
    O, D = rays
    (corners, face_normals, base_color, roughness, metallic, emissive, tex_offset, tex_w, tex_h, wrap, tex_data,
     colors) = mesh
    P, N, NG, albedo, rough, metal, emis = out
    for k in range(k0, k1):
        if k + AHEAD < n:
            ahead = prim[sel[k + AHEAD]]
            prefetch_row(corners, ahead)
            prefetch_row(face_normals, ahead)
        i = sel[k]
        tri = prim[i]
        c = corners[tri]
        w1, w2 = bu[i], bv[i]
        w0 = 1.0 - w1 - w2
        gx, gy, gz = face_normals[tri, 0], face_normals[tri, 1], face_normals[tri, 2]
        if gx * D[i, 0] + gy * D[i, 1] + gz * D[i, 2] > 0:
            gx, gy, gz = -gx, -gy, -gz
        NG[k, 0], NG[k, 1], NG[k, 2] = gx, gy, gz
        lift = hit_lift(O[i, 0], O[i, 1], O[i, 2], D[i, 0] * t[i], D[i, 1] * t[i], D[i, 2] * t[i], gx, gy, gz)
        P[k, 0] = O[i, 0] + D[i, 0] * t[i] + gx * lift
        P[k, 1] = O[i, 1] + D[i, 1] * t[i] + gy * lift
        P[k, 2] = O[i, 2] + D[i, 2] * t[i] + gz * lift
        m = int(c[15])
        u, v = textures.hit_uv(c, w1, w2)
        nx = w0 * c[0] + w1 * c[3] + w2 * c[6]
        ny = w0 * c[1] + w1 * c[4] + w2 * c[7]
        nz = w0 * c[2] + w1 * c[5] + w2 * c[8]
        ln = math.sqrt(nx * nx + ny * ny + nz * nz)
        if ln < 1e-20:
            nx, ny, nz, ln = gx, gy, gz, 1.0
        nx, ny, nz = nx / ln, ny / ln, nz / ln
        if tex_offset[m, LAYER_NORMAL] >= 0:  # each texture a call, made only where the layer is there
            nx, ny, nz = textures.normal_mapped(c, m, w0, w1, w2, nx, ny, nz, u, v,
                                                (tex_offset, tex_w, tex_h, wrap, tex_data))
        if nx * gx + ny * gy + nz * gz < 0:
            nx, ny, nz = -nx, -ny, -nz
        N[k, 0], N[k, 1], N[k, 2] = nx, ny, nz
        r = g = b = 1.0
        if tex_offset[m, LAYER_BASE] >= 0:
            r, g, b, _ = textures.sample(tex_data, tex_offset, tex_w, tex_h, wrap, m, LAYER_BASE, u, v)
        if colors.shape[0] > 1:  # vertex colours (colors: one white row where the scene has none)
            vc = colors[tri]
            r *= w0 * vc[0] + w1 * vc[3] + w2 * vc[6]
            g *= w0 * vc[1] + w1 * vc[4] + w2 * vc[7]
            b *= w0 * vc[2] + w1 * vc[5] + w2 * vc[8]
        albedo[k, 0], albedo[k, 1], albedo[k, 2] = base_color[m, 0] * r, base_color[m, 1] * g, base_color[m, 2] * b
        if tex_offset[m, LAYER_ORM] >= 0:
            _, rough[k], metal[k], _ = textures.sample(tex_data, tex_offset, tex_w, tex_h, wrap, m, LAYER_ORM, u, v)
        else:
            rough[k], metal[k] = roughness[m], metallic[m]
        if tex_offset[m, LAYER_EMISSION] >= 0:
            emis[k, 0], emis[k, 1], emis[k, 2], _ = textures.sample(tex_data, tex_offset, tex_w, tex_h, wrap, m,
                                                                    LAYER_EMISSION, u, v)
        else:
            emis[k, 0], emis[k, 1], emis[k, 2] = emissive[m, 0], emissive[m, 1], emissive[m, 2]


@njit(cache=True, error_model="numpy", parallel=True, fastmath=True)
def shade_hits(sel, hits, rays, mesh, out):
    """Surface data at the hits of rays sel[k] (written at k): position, normals facing the ray
    (the shading normal normal-mapped), textured albedo, roughness, metallic and emission.
    hits: (triangle, barycentric u, v, distance) per ray; rays: (origins, directions); mesh:
    SceneData.mesh_args, whose corners hold per triangle its 3 vertex normals, 3 uvs, material
    and tangents (rt/mesh.py), so an incoherent hit reads one row of mesh data, not one per
    array; out: the Surface's arrays (p, n, ng, albedo, roughness, metallic, emissive)."""
    n = sel.shape[0]
    for r in prange((n + SHADE_RUN - 1) // SHADE_RUN):  # the records passed whole: see _shade_run
        _shade_run(r * SHADE_RUN, min(n, (r + 1) * SHADE_RUN), n, sel, hits, rays, mesh, out)


@njit(cache=True, error_model="numpy")
def covered_pixels(geometry, height, width, idx, row_start):
    """Top-row-first pixel ids that the packed G-buffer (bottom row first, as GL reads) covers
    (a non-zero depth word), written to idx[:m] (room for height * width), with row y's pixels
    at idx[row_start[y]:row_start[y + 1]] (row_start: height + 1 entries); returns m."""
    m = 0
    for y in range(height):
        row_start[y] = m
        row = height - 1 - y
        for x in range(width):
            if geometry[row, x, 0] != 0:
                idx[m] = y * width + x
                m += 1
    row_start[height] = m
    return m


@njit(cache=True, error_model="numpy", nogil=True)
def primary_pixels(t, prim, d, fwd, covered, idx, depth):
    """From primary rays' hits (t, prim: -1 where missed) along unit directions d: which pixels
    are covered, their ids in order (idx[:m]; m is returned) and every pixel's linear depth
    t (d . fwd), 0 where uncovered. One pass instead of numpy's masks, gathers and scatters."""
    m = 0
    f0, f1, f2 = fwd[0], fwd[1], fwd[2]
    for i in range(t.shape[0]):
        hit = prim[i] >= 0
        covered[i] = hit
        if hit:
            idx[m] = i
            m += 1
            depth[i] = t[i] * (d[i, 0] * f0 + d[i, 1] * f1 + d[i, 2] * f2)
        else:
            depth[i] = 0.0
    return m


@njit(cache=True, error_model="numpy")
def _pixel_ray(p, width, height, tan_half, jitter, right, up, fwd):
    """The ray through pixel p (row 0 at the top) at its centre moved by jitter (pixels: right,
    down), of unit length along fwd."""
    y, x = p // width, p % width
    sx = ((x + 0.5 + jitter[0]) / width * 2.0 - 1.0) * tan_half * (width / height)
    sy = (1.0 - (y + 0.5 + jitter[1]) / height * 2.0) * tan_half
    return (right[0] * sx + up[0] * sy + fwd[0], right[1] * sx + up[1] * sy + fwd[1],
            right[2] * sx + up[2] * sy + fwd[2])


@njit(cache=True, error_model="numpy", parallel=True, fastmath=True)
def camera_rays(eye, right, up, fwd, tan_half, jitter, width, height, origin, direction):
    """Primary rays through pixel centres moved by jitter (_pixel_ray), row 0 at the top (as
    app/camera.py: primary_rays)."""
    for p in prange(width * height):
        dx, dy, dz = _pixel_ray(p, width, height, tan_half, jitter, right, up, fwd)
        inv = 1.0 / math.sqrt(dx * dx + dy * dy + dz * dz)
        direction[p, 0], direction[p, 1], direction[p, 2] = dx * inv, dy * inv, dz * inv
        origin[p, 0], origin[p, 1], origin[p, 2] = eye[0], eye[1], eye[2]


HALF_EXP = np.array([2.0 ** (e - 15) for e in range(32)], np.float32)


@njit(cache=True, error_model="numpy")
def _half(h):
    """IEEE half (low 16 bits of h) to float; the G-buffer holds no infinities or NaNs."""
    e = (h >> 10) & 0x1F
    f = np.float32(h & 0x3FF)
    v = f * np.float32(2.0 ** -24) if e == 0 else (np.float32(1.0) + f * np.float32(1 / 1024)) * HALF_EXP[e]
    return -v if (h >> 15) & 1 else v


@njit(cache=True, error_model="numpy")
def _snorm16(u):
    x = np.int32(u & 0xFFFF)
    x = x - 65536 if x >= 32768 else x
    return max(np.float32(x) / np.float32(32767.0), np.float32(-1.0))


@njit(cache=True, error_model="numpy", fastmath=True)
def _octahedral(word):
    """A unit vector from its octahedral encoding (2 x snorm16, as GLSL's packSnorm2x16)."""
    x, y = _snorm16(word), _snorm16(word >> 16)
    z = np.float32(1.0) - abs(x) - abs(y)
    if z < 0:
        sx = np.float32(1.0) if x >= 0 else np.float32(-1.0)
        sy = np.float32(1.0) if y >= 0 else np.float32(-1.0)
        x, y = (np.float32(1.0) - abs(y)) * sx, (np.float32(1.0) - abs(x)) * sy
    inv = np.float32(1.0) / np.sqrt(max(x * x + y * y + z * z, np.float32(1e-20)))
    return x * inv, y * inv, z * inv


@njit(cache=True, error_model="numpy", parallel=True, fastmath=True)
def unpack_gbuffer(packed, cover, camera, out, pixels, G):
    """The packed G-buffer (shaders/gbuffer_pack.frag; bottom row first; depth_bits: its first
    word read as float32) -> per-covered-pixel surface arrays, and per-pixel view directions,
    linear depths and coverage, top row first. Positions come back from the pixel's ray and
    depth (the ray through the pixel's centre moved by jitter, as the raster's projection was),
    lifted off the surface by their error (hit_lift).
    Row by row (idx and row_start from covered_pixels): no division per pixel. G (9, M): p, n and
    ng again as rows, what the ray generators read (rt/embree/raygen.py: surface_soa).
    packed: (geometry, depth_bits, material); cover: (idx, row_start); camera: (eye, right, up,
    fwd, tan_half, jitter); out: the covered pixels' Surface arrays (p, n, ng, albedo,
    roughness, metallic, emissive); pixels: every pixel's (view_dir, depth, covered)."""
    for y in prange(packed[0].shape[0]):  # the records passed whole: see _shade_run
        _unpack_row(y, packed, cover, camera, out, pixels, G)


@njit(cache=True, error_model="numpy", fastmath=True)
def _unpack_row(y, packed, cover, camera, out, pixels, G):
    """unpack_gbuffer for pixel row y (top first)."""
    geometry, depth_bits, material = packed
    idx, row_start = cover
    eye, right, up, fwd, tan_half, jitter = camera
    P, N, NG, albedo, rough, metal, emis = out
    view_dir, depth, covered = pixels
    height, width = geometry.shape[0], geometry.shape[1]
    aspect = width / height
    r = height - 1 - y
    sy = (1.0 - (y + 0.5 + jitter[1]) / height * 2.0) * tan_half  # as _pixel_ray
    for x in range(width):
        p = y * width + x
        sx = ((x + 0.5 + jitter[0]) / width * 2.0 - 1.0) * tan_half * aspect
        dx = right[0] * sx + up[0] * sy + fwd[0]
        dy = right[1] * sx + up[1] * sy + fwd[1]
        dz = right[2] * sx + up[2] * sy + fwd[2]
        inv = 1.0 / math.sqrt(dx * dx + dy * dy + dz * dz)
        view_dir[p, 0], view_dir[p, 1], view_dir[p, 2] = dx * inv, dy * inv, dz * inv
        depth[p] = 0.0
        covered[p] = False
    for j in range(row_start[y], row_start[y + 1]):
        p = idx[j]
        x = p - y * width
        d = depth_bits[r, x, 0]
        depth[p] = d
        covered[p] = True
        # the pixel-centre ray has unit length along fwd, so depth scales it to the surface
        sx = ((x + 0.5 + jitter[0]) / width * 2.0 - 1.0) * tan_half * aspect
        dx = right[0] * sx + up[0] * sy + fwd[0]
        dy = right[1] * sx + up[1] * sy + fwd[1]
        dz = right[2] * sx + up[2] * sy + fwd[2]
        nx, ny, nz = _octahedral(geometry[r, x, 1])
        gx, gy, gz = _octahedral(geometry[r, x, 2])
        lift = hit_lift(eye[0], eye[1], eye[2], dx * d, dy * d, dz * d, gx, gy, gz)
        px, py, pz = eye[0] + dx * d + gx * lift, eye[1] + dy * d + gy * lift, eye[2] + dz * d + gz * lift
        P[j, 0], P[j, 1], P[j, 2] = px, py, pz
        N[j, 0], N[j, 1], N[j, 2] = nx, ny, nz
        NG[j, 0], NG[j, 1], NG[j, 2] = gx, gy, gz
        G[PX, j], G[PY, j], G[PZ, j], G[NX, j], G[NY, j], G[NZ, j] = px, py, pz, nx, ny, nz
        G[GX, j], G[GY, j], G[GZ, j] = gx, gy, gz
        c, m0, m1, m2 = geometry[r, x, 3], material[r, x, 0], material[r, x, 1], material[r, x, 2]
        albedo[j, 0], albedo[j, 1], albedo[j, 2] = _half(c), _half(c >> 16), _half(m2)
        metal[j] = _half(m2 >> 16)
        emis[j, 0], emis[j, 1], emis[j, 2] = _half(m0), _half(m0 >> 16), _half(m1)
        rough[j] = _half(m1 >> 16)


@njit(cache=True, error_model="numpy", parallel=True)
def pack_rgba_flipped(image, height, width, channels, out):
    """(H*W, C) top-row-first -> (H, W, 4) bottom-row-first for a GL texture upload."""
    for p in prange(height * width):
        y, x = p // width, p % width
        r = height - 1 - y
        for a in range(4):
            if a < channels:
                out[r, x, a] = image[p, a]
            elif channels == 1 and a < 3:
                out[r, x, a] = image[p, 0]
            else:
                out[r, x, a] = 1.0 if a == 3 else 0.0


@njit(cache=True, error_model="numpy", parallel=True)
def scatter_rows(out, idx, values):
    """out[idx[j]] = values[j] for (M,C) values."""
    for j in prange(idx.shape[0]):
        for a in range(values.shape[1]):
            out[idx[j], a] = values[j, a]


@njit(cache=True, error_model="numpy", parallel=True)
def fill_rows(out, value):
    """out[:] = value over numba's threads: NumPy fills on one thread, a step that would not
    shrink with the rest of a pass on many cores."""
    flat = out.reshape(out.size)
    for j in prange(flat.shape[0]):
        flat[j] = value


@njit(cache=True, error_model="numpy", fastmath=True)
def environment_terms(kind, color, horizon, zenith, ground):
    """An environment (kinds as rt/environment.py: env_args) as the float32 terms environment_rgb
    takes: a constant colour, the analytic sky's horizon, zenith and ground colours
    (scenes/model.py: sky_radiance) times its strength, and a map's strength and u shift, zero
    where they do not apply."""
    f, zero = np.float32, np.float32(0.0)
    c0 = f(color[0]) if kind == 2 else zero
    k = (f(color[0]), f(color[1]), f(color[2])) if kind == 1 else (zero, zero, zero)
    ms, mu = (f(color[0]), f(color[1])) if kind == 3 else (zero, zero)
    return (k[0], k[1], k[2], f(horizon[0]) * c0, f(horizon[1]) * c0, f(horizon[2]) * c0,
            f(zenith[0]) * c0, f(zenith[1]) * c0, f(zenith[2]) * c0,
            f(ground[0]) * c0, f(ground[1]) * c0, f(ground[2]) * c0, ms, mu)


@njit(cache=True, error_model="numpy", fastmath=True)
def equirect_uv(x, y, z, shift):
    """Where a unit direction falls on an equirectangular map turned by `shift` in u (as
    scenes/model.py's equirect_uv): u = atan2(x, -z) / 2pi + shift (mod 1), v = acos(y) / pi."""
    one = np.float32(1.0)
    u = np.float32(np.arctan2(x, -z)) * np.float32(0.15915494309189535) + shift
    u -= np.floor(u)
    return u, np.float32(np.arccos(min(max(y, -one), one))) * np.float32(0.3183098861837907)


@njit(cache=True, error_model="numpy", fastmath=True)
def env_map_rgb(x, y, z, texels, shift):
    """Bilinear radiance of an equirectangular map towards (x, y, z), read as scenes/model.py's
    equirect_lookup reads it (u wraps, v clamps)."""
    h, w = texels.shape[0], texels.shape[1]
    one = np.float32(1.0)
    u, v = equirect_uv(x, y, z, shift)
    fx, fy = u * w - np.float32(0.5), v * h - np.float32(0.5)
    x0, y0 = np.floor(fx), np.floor(fy)
    tx, ty = fx - x0, fy - y0
    ix0 = int(x0) % w
    ix1 = (ix0 + 1) % w
    iy0 = min(max(int(y0), 0), h - 1)
    iy1 = min(max(int(y0) + 1, 0), h - 1)
    a, b, c = (one - tx) * (one - ty), tx * (one - ty), (one - tx) * ty
    d = tx * ty
    return (a * texels[iy0, ix0, 0] + b * texels[iy0, ix1, 0] + c * texels[iy1, ix0, 0] + d * texels[iy1, ix1, 0],
            a * texels[iy0, ix0, 1] + b * texels[iy0, ix1, 1] + c * texels[iy1, ix0, 1] + d * texels[iy1, ix1, 1],
            a * texels[iy0, ix0, 2] + b * texels[iy0, ix1, 2] + c * texels[iy1, ix0, 2] + d * texels[iy1, ix1, 2])


@njit(cache=True, error_model="numpy", fastmath=True)
def environment_rgb(x, y, z, terms, texels):
    """The environment's radiance towards a unit direction: black, a constant colour, the sky
    (from horizon to zenith above and half the horizon to the ground below: branch-free
    float32, so that loops over pixels or rays vectorise) or a map's texels."""
    k0, k1, k2, h0, h1, h2, z0, z1, z2, g0, g1, g2, ms, mu = terms
    one, zero = np.float32(1.0), np.float32(0.0)
    if ms != zero:
        r, g, b = env_map_rgb(x, y, z, texels, mu)
        return r * ms, g * ms, b * ms
    y = min(max(y, -one), one)
    u = np.sqrt(abs(y))
    up = y >= zero
    s = (one - u) * (one if up else np.float32(0.5))
    return (k0 + h0 * s + (z0 if up else g0) * u, k1 + h1 * s + (z1 if up else g1) * u,
            k2 + h2 * s + (z2 if up else g2) * u)


@njit(cache=True, error_model="numpy", parallel=True, fastmath=True)
def background_fill(out, view_dir, covered, kind, color, horizon, zenith, ground, texels):
    """Uncovered pixels get the environment's radiance (kinds as rt/environment.py: env_args);
    covered ones 0. In float32, branch-free for the gradients, so that it vectorises: it runs
    every frame of every ray-traced pass."""
    terms = environment_terms(kind, color, horizon, zenith, ground)
    zero = np.float32(0.0)
    for p in prange(out.shape[0]):
        r, g, b = environment_rgb(view_dir[p, 0], view_dir[p, 1], view_dir[p, 2], terms, texels)
        cov = covered[p]
        out[p, 0] = zero if cov else r
        out[p, 1] = zero if cov else g
        out[p, 2] = zero if cov else b


# Kernels run from two places: the main (or viewer compute) thread, where numba's own threads
# parallelise them, and the tracer's chunk workers, which are already parallel and must not
# launch numba's thread pool from several threads at once: there the serial, GIL-free twin runs.
_worker = threading.local()


def in_worker() -> bool:
    return getattr(_worker, "on", False)


@contextmanager
def serial_kernels():
    """Kernels called in this block (on this thread) run serially."""
    was = in_worker()
    _worker.on = True
    try:
        yield
    finally:
        _worker.on = was


class _Dual:
    def __init__(self, kernel):
        f = kernel.py_func
        twin = types.FunctionType(f.__code__, f.__globals__, f.__name__ + "_serial", f.__defaults__, f.__closure__)
        twin.__qualname__ = f.__qualname__ + "_serial"  # its own cache entry
        self.parallel = kernel
        self.serial = njit(cache=True, nogil=True, fastmath=True, error_model="numpy")(twin)
        self.__doc__ = f.__doc__

    def __call__(self, *args):
        return (self.serial if in_worker() else self.parallel)(*args)


shade_hits = _Dual(shade_hits)
uniforms = _Dual(uniforms)
scatter_rows = _Dual(scatter_rows)
pixel_keys = _Dual(pixel_keys)
