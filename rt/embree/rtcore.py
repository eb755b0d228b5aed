"""Embree's C API, called directly: scene building from Python (ctypes), ray queries from
compiled code (numba).

embreex ships libembree4 but its `run` takes whole arrays and returns fresh ones, so every
call costs Python work under the GIL and allocations (an intersect call makes six output
arrays). Here ray queries are plain calls of `rtcIntersect8` / `rtcOccluded16` (packets)
from numba kernels that run without the GIL: a chunk's tracing is one GIL-free call writing
into the caller's arrays, and kernels may trace rays as they make them. The single-ray calls
(`intersect1`, `occluded1`) stay as the reference the packets are tested against. The library is embreex's own
copy, so the BVH and traversal are the same Embree 4 as before.

Layouts follow embree4/rtcore_ray.h: RTCRay is 12 words (org, tnear, dir, time, tfar, mask,
id, flags), RTCHit follows it (Ng, u, v, primID, geomID, instID), 16-byte aligned.
"""
from __future__ import annotations

import ctypes
import glob
import os

import numpy as np
from llvmlite import binding as llvm
from numba import types

from core.errors import UserError
from rt.embree.jit import njit
from rt.embree.kernels import next_block, take_many

INVALID = np.uint32(0xFFFFFFFF)
MISS_T = np.float32(1e30)  # t of a ray that hit nothing (rt.tracer.INF)
GEOMETRY_TRIANGLE, BUFFER_INDEX, BUFFER_VERTEX = 0, 0, 1
FORMAT_UINT3, FORMAT_FLOAT3 = 0x5003, 0x9003
SCENE_FLAG_ROBUST = 1 << 2
# RTCRayHit (at most 28 words with instance ids) on cache lines of its own: 32 words from a
# 64-byte boundary, and room to find one, so that no two threads' ray buffers share a line
RAYHIT_WORDS = 48


def library_path() -> str:
    """libembree4 as shipped in embreex's wheel (embreex.libs), else the system's."""
    import embreex

    site = os.path.dirname(os.path.dirname(embreex.__file__))
    found = sorted(glob.glob(os.path.join(site, "embreex.libs", "libembree4*.so*")))
    if found:
        return found[0]
    import ctypes.util

    name = ctypes.util.find_library("embree4")
    if name is None:
        raise UserError("libembree4 not found (neither in embreex's wheel nor on the system)")
    return name


_lib = None  # libembree4 through ctypes, once load() ran


def load():
    """Load libembree4 (once): for ctypes here and for the compiled kernels, which resolve
    rtcOccluded1 / rtcIntersect1 by name when they are compiled or loaded from the cache."""
    global _lib
    if _lib is not None:
        return _lib
    path = library_path()
    llvm.load_library_permanently(path)  # so that compiled kernels resolve rtc* by name
    lib = ctypes.CDLL(path)
    P = ctypes.c_void_p
    for name, res, args in (("rtcNewDevice", P, [ctypes.c_char_p]), ("rtcReleaseDevice", None, [P]),
                            ("rtcGetDeviceError", ctypes.c_int, [P]), ("rtcNewScene", P, [P]),
                            ("rtcReleaseScene", None, [P]), ("rtcCommitScene", None, [P]),
                            ("rtcSetSceneFlags", None, [P, ctypes.c_int]),
                            ("rtcNewGeometry", P, [P, ctypes.c_int]),
                            ("rtcSetNewGeometryBuffer", P, [P, ctypes.c_int, ctypes.c_uint, ctypes.c_int,
                                                            ctypes.c_size_t, ctypes.c_size_t]),
                            ("rtcCommitGeometry", None, [P]), ("rtcAttachGeometry", ctypes.c_uint, [P, P]),
                            ("rtcReleaseGeometry", None, [P]), ("rtcSetGeometryUserData", None, [P, P]),
                            ("rtcSetGeometryIntersectFilterFunction", None, [P, P]),
                            ("rtcSetGeometryOccludedFilterFunction", None, [P, P])):
        fn = getattr(lib, name)
        fn.restype, fn.argtypes = res, args
    _lib = lib
    return lib


# (scene, ray, arguments): pointers passed as integers, the same registers on x86-64 and arm64
_occluded1 = types.ExternalFunction("rtcOccluded1", types.void(types.uintp, types.uintp, types.uintp))
_intersect1 = types.ExternalFunction("rtcIntersect1", types.void(types.uintp, types.uintp, types.uintp))


class EmbreeScene:
    """One triangle mesh, committed (BVH built) on creation; `handle` is the RTCScene that the
    kernels below take. alpha (rt/embree/alpha.AlphaData): masked materials, whose cut-away
    hits a filter function rejects for every kind of ray."""

    def __init__(self, positions: np.ndarray, indices: np.ndarray, alpha=None):
        positions = np.ascontiguousarray(positions, np.float32).reshape(-1, 3)
        indices = np.ascontiguousarray(indices, np.uint32).reshape(-1, 3)
        load()
        self.device = _lib.rtcNewDevice(None)
        if not self.device:
            raise UserError("Embree could not create a device")
        self.scene = _lib.rtcNewScene(self.device)
        # robust traversal, as embreex's scenes: the same hits as before, to the bit (without it,
        # rays grazing shared edges and coplanar overlaps resolve differently)
        _lib.rtcSetSceneFlags(self.scene, SCENE_FLAG_ROBUST)
        geometry = _lib.rtcNewGeometry(self.device, GEOMETRY_TRIANGLE)
        # Embree's own buffers (padded as it needs) filled with one copy each
        vb = _lib.rtcSetNewGeometryBuffer(geometry, BUFFER_VERTEX, 0, FORMAT_FLOAT3, 12, max(len(positions), 1))
        ib = _lib.rtcSetNewGeometryBuffer(geometry, BUFFER_INDEX, 0, FORMAT_UINT3, 12, len(indices))
        if len(positions):
            ctypes.memmove(vb, positions.ctypes.data, positions.nbytes)
        if len(indices):
            ctypes.memmove(ib, indices.ctypes.data, indices.nbytes)
        self.alpha = alpha
        if alpha is not None:
            _lib.rtcSetGeometryUserData(geometry, alpha.pointer)
            _lib.rtcSetGeometryIntersectFilterFunction(geometry, alpha.function)
            _lib.rtcSetGeometryOccludedFilterFunction(geometry, alpha.function)
        _lib.rtcCommitGeometry(geometry)
        _lib.rtcAttachGeometry(self.scene, geometry)
        _lib.rtcReleaseGeometry(geometry)
        _lib.rtcCommitScene(self.scene)
        error = _lib.rtcGetDeviceError(self.device)
        if error:
            self.close()
            raise UserError(f"Embree could not build the scene (error {error})")
        self.handle = int(self.scene)

    def close(self) -> None:
        if getattr(self, "scene", None):
            _lib.rtcReleaseScene(self.scene)
            self.scene = None
            self.handle = 0
        if getattr(self, "device", None):
            _lib.rtcReleaseDevice(self.device)
            self.device = None

    def __del__(self):
        self.close()


@njit(cache=True, error_model="numpy")
def ray_buffer():
    """A per-call RTCRayHit: the array and the word offset of its 64-byte aligned start."""
    buf = np.empty(RAYHIT_WORDS, np.float32)
    return buf, ((64 - buf.ctypes.data % 64) % 64) // 4


@njit(cache=True, error_model="numpy")
def set_ray(buf, words, b, ox, oy, oz, dx, dy, dz, tmax):
    buf[b] = ox
    buf[b + 1] = oy
    buf[b + 2] = oz
    buf[b + 3] = 0.0  # tnear
    buf[b + 4] = dx
    buf[b + 5] = dy
    buf[b + 6] = dz
    buf[b + 7] = 0.0  # time
    buf[b + 8] = tmax
    words[b + 9] = INVALID  # mask: every geometry
    words[b + 10] = 0  # id
    words[b + 11] = 0  # flags


@njit(cache=True, error_model="numpy")
def occluded1(scene, buf, words, b, ox, oy, oz, dx, dy, dz, tmax):
    """True if something lies on the ray within (0, tmax)."""
    set_ray(buf, words, b, ox, oy, oz, dx, dy, dz, tmax)
    _occluded1(scene, buf.ctypes.data + 4 * b, 0)
    return buf[b + 8] < 0.0  # Embree sets tfar to -inf on a hit


@njit(cache=True, error_model="numpy")
def intersect1(scene, buf, words, b, ox, oy, oz, dx, dy, dz, tmax):
    """The closest hit within (0, tmax): (t, prim, u, v), prim -1 and t MISS_T on a miss."""
    set_ray(buf, words, b, ox, oy, oz, dx, dy, dz, tmax)
    words[b + 17] = INVALID  # primID
    words[b + 18] = INVALID  # geomID
    _intersect1(scene, buf.ctypes.data + 4 * b, 0)
    if words[b + 18] == INVALID:
        return MISS_T, np.int32(-1), np.float32(0.0), np.float32(0.0)
    return buf[b + 8], np.int32(words[b + 17]), buf[b + 15], buf[b + 16]


@njit(cache=True, error_model="numpy", nogil=True)
def occluded(scene, o, d, tmax, out):
    """out[i] = ray i is blocked within tmax[i]; o, d (n,3) float32."""
    occluded_range(scene, packet(OCCLUDE_PACKET), o, d, tmax, out, 0, o.shape[0])


@njit(cache=True, error_model="numpy", nogil=True)
def intersect(scene, o, d, tmax, t, prim, u, v):
    """Closest hits of rays i within tmax[i] into t, prim, u, v (see intersect1)."""
    intersect_range(scene, packet(HIT_PACKET), o, d, tmax, t, prim, u, v, 0, o.shape[0])


# -- tracing targets: a scene handle, and where the rays traced are logged ---------------------
# The frame kernels take a target `tr` = (handle, log, count): handle 0 means "do not trace"
# (generators pack their rays for the caller instead); log is an (n, LOG_WIDTH) float32 array
# (or an empty one: no logging) into which every ray traced (the generators' through log_put,
# trace_intersect's) is written, for bench --perf to trace again. A caller reserves a run of
# slots for a step's rays (log_reserve: count advances atomically), so that each run of the log
# holds one thread's neighbouring rays, as it traced them; slots of rays not traced stay marked.
LOG_WIDTH = 8  # origin, direction, tmax, kind (0 occlusion, 1 closest hit, -1 a slot not traced)


def target(handle: int, log: np.ndarray | None = None, count: np.ndarray | None = None) -> tuple:
    """A tracing target for the kernels: the scene handle (0: pack, do not trace) and an
    optional ray log with its counter (tracer.RayLog)."""
    if log is None:
        log, count = np.empty((0, LOG_WIDTH), np.float32), np.zeros(1, np.int64)
    return np.int64(handle), log, count


@njit(cache=True, error_model="numpy")
def no_trace(tr):
    """tr's log with no scene: generators given it pack their rays instead of tracing them."""
    return np.int64(0), tr[1], tr[2]


@njit(cache=True, error_model="numpy")
def log_reserve(tr, n):
    """The first of n log slots for the caller's next rays, or -1 when tr does not log."""
    if tr[1].shape[0] == 0:
        return np.int64(-1)
    return take_many(tr[2], n)


@njit(cache=True, error_model="numpy")
def log_put(tr, slot, kind, ox, oy, oz, dx, dy, dz, tmax):
    """Write a ray (or with kind -1, a slot not traced) at a reserved slot; past the end of the
    log (or slot -1) nothing is kept (RayLog.overflowed counts it)."""
    log = tr[1]
    if 0 <= slot < log.shape[0]:
        log[slot, 0], log[slot, 1], log[slot, 2], log[slot, 3], log[slot, 4], log[slot, 5] = ox, oy, oz, dx, dy, dz
        log[slot, 6], log[slot, 7] = tmax, kind


@njit(cache=True, error_model="numpy", nogil=True)
def trace_intersect(tr, o, d, tmax, t, prim, u, v):
    """intersect() on the target's scene, the rays logged if tr logs."""
    at = log_reserve(tr, o.shape[0])
    if at >= 0:
        for i in range(o.shape[0]):
            log_put(tr, at + i, 1.0, o[i, 0], o[i, 1], o[i, 2], d[i, 0], d[i, 1], d[i, 2], tmax[i])
    intersect(tr[0], o, d, tmax, t, prim, u, v)


@njit(cache=True, error_model="numpy", nogil=True)
def occluded_blocks(counter, bounds, scene, o, d, tmax, out):
    """occluded() as one worker of Tracer.run_parallel: blocks of rays (bounds) taken in turn
    until none is left, no Python per block (Embree's own throughput on these rays)."""
    n = o.shape[0]
    pk = packet(OCCLUDE_PACKET)
    while True:
        b0, b1 = next_block(counter, bounds)
        if b0 >= n:
            return 0
        occluded_range(scene, pk, o, d, tmax, out, b0, b1)


@njit(cache=True, error_model="numpy", nogil=True)
def intersect_blocks(counter, bounds, scene, o, d, tmax, t, prim, u, v):
    """intersect() as occluded_blocks splits its work."""
    n = o.shape[0]
    pk = packet(HIT_PACKET)
    while True:
        b0, b1 = next_block(counter, bounds)
        if b0 >= n:
            return 0
        intersect_range(scene, pk, o, d, tmax, t, prim, u, v, b0, b1)


# -- packets: rtcOccluded16 and rtcIntersect8 -------------------------------------------------
# RTCRayHitN (embree4/rtcore_ray.h) is structure-of-arrays, a lane per ray in each of FIELDS: the
# ray's org_x, org_y, org_z, tnear, dir_x, dir_y, dir_z, time, tfar, mask, id, flags, then the
# hit's Ng_x, Ng_y, Ng_z, u, v, primID, geomID, instID (and instPrimID where built with instance
# arrays). Embree walks a packet's rays through the BVH together, in SIMD, switching to single
# rays where they part; on incoherent bounce rays packets traced 1.26-1.37x the rays a second of
# rtcIntersect1 (report/HISTORY.md). Camera rays go as tiles of TILE_W x TILE_H pixels
# (intersect_tiles), whose rays share most nodes. The widths, measured on an AVX-512 Xeon (2
# cores): closest hits as packets of 8 (camera rays 89-93 ms a million on one thread against
# 111-116 as packets of 16; GI frames 3-5 % faster), occlusion as packets of 16 (the AO pass
# 32 ms at 1280x720 against 36-38 as packets of 8); the same hits to the bit either way.
OCCLUDE_PACKET, HIT_PACKET = 16, 8
TILE_W, TILE_H = 4, HIT_PACKET // 4
FIELDS = 21  # every field above, with room for instPrimID
_TNEAR, _TIME, _T_FAR, _MASK, _ID, _FLAGS, _U, _V, _PRIM, _GEOM = 3, 7, 8, 9, 10, 11, 15, 16, 17, 18
# (valid, scene, rayhit, arguments)
_intersect_packet = types.ExternalFunction(f"rtcIntersect{HIT_PACKET}", types.void(types.uintp, types.uintp,
                                                                                  types.uintp, types.uintp))
_occluded_packet = types.ExternalFunction(f"rtcOccluded{OCCLUDE_PACKET}", types.void(types.uintp, types.uintp,
                                                                                    types.uintp, types.uintp))


@njit(cache=True, error_model="numpy")
def _aligned(n, dtype):
    """An array of n elements starting on a 64-byte boundary (a view into a larger one)."""
    buf = np.empty(n + 16, dtype)
    skip = ((64 - buf.ctypes.data % 64) % 64) // buf.itemsize
    return buf[skip:skip + n]


@njit(cache=True, error_model="numpy")
def packet(lanes):
    """A per-call RTCRayHitN (SoA) of `lanes` lanes (OCCLUDE_PACKET for occluded_packet,
    HIT_PACKET for intersect_packet) and its valid mask, 64-byte aligned: (ray, its words, valid)."""
    ray = _aligned(FIELDS * lanes, np.float32)
    return ray, ray.view(np.uint32), _aligned(lanes, np.int32)


@njit(cache=True, error_model="numpy")
def set_lane(ray, words, w, k, ox, oy, oz, dx, dy, dz, tmax):
    """Lane k of a packet of w lanes (the packet's width, a constant where called, so that the
    offsets are too): the ray from o along d within (0, tmax), no hit yet."""
    ray[k], ray[w + k], ray[2 * w + k], ray[_TNEAR * w + k] = ox, oy, oz, 0.0
    ray[4 * w + k], ray[5 * w + k], ray[6 * w + k], ray[_TIME * w + k] = dx, dy, dz, 0.0
    ray[_T_FAR * w + k] = tmax
    words[_MASK * w + k] = INVALID  # mask: every geometry
    words[_ID * w + k] = 0
    words[_FLAGS * w + k] = 0
    words[_PRIM * w + k] = INVALID
    words[_GEOM * w + k] = INVALID


@njit(cache=True, error_model="numpy")
def _lanes_valid(ray, words, valid, w, lanes):
    """Lanes 0..lanes-1 of a packet of w valid; the others a copy of lane 0, masked off."""
    for k in range(w):
        valid[k] = -1 if k < lanes else 0
        if k >= lanes:
            set_lane(ray, words, w, k, ray[0], ray[w], ray[2 * w], ray[4 * w], ray[5 * w], ray[6 * w],
                     ray[_T_FAR * w])


@njit(cache=True, error_model="numpy")
def occluded_packet(scene, pk, lanes):
    """Trace the first `lanes` rays of a packet(OCCLUDE_PACKET) for occlusion; lane k is blocked
    when blocked_lane(pk, k)."""
    ray, words, valid = pk
    _lanes_valid(ray, words, valid, OCCLUDE_PACKET, lanes)
    _occluded_packet(valid.ctypes.data, scene, ray.ctypes.data, 0)


@njit(cache=True, error_model="numpy")
def blocked_lane(pk, k):
    return pk[0][_T_FAR * OCCLUDE_PACKET + k] < 0.0  # Embree sets tfar to -inf on a hit


@njit(cache=True, error_model="numpy")
def intersect_packet(scene, pk, lanes):
    """Trace the first `lanes` rays of a packet(HIT_PACKET) to their closest hits; hit_lane(pk, k)
    reads lane k's."""
    ray, words, valid = pk
    _lanes_valid(ray, words, valid, HIT_PACKET, lanes)
    _intersect_packet(valid.ctypes.data, scene, ray.ctypes.data, 0)


@njit(cache=True, error_model="numpy")
def hit_lane(pk, k):
    """Lane k's closest hit as intersect1 returns it: (t, prim, u, v), prim -1 and t MISS_T on a miss."""
    ray, words, w = pk[0], pk[1], HIT_PACKET
    if words[_GEOM * w + k] == INVALID:
        return MISS_T, np.int32(-1), np.float32(0.0), np.float32(0.0)
    return ray[_T_FAR * w + k], np.int32(words[_PRIM * w + k]), ray[_U * w + k], ray[_V * w + k]


@njit(cache=True, error_model="numpy")
def _fill_lanes(pk, w, o, d, tmax, p0, i1):
    """The lanes of a packet of w from rays p0, p0 + 1, ... (before i1) of o, d, tmax; returns how many."""
    lanes = min(w, i1 - p0)
    for k in range(lanes):
        i = p0 + k
        set_lane(pk[0], pk[1], w, k, o[i, 0], o[i, 1], o[i, 2], d[i, 0], d[i, 1], d[i, 2], tmax[i])
    return lanes


@njit(cache=True, error_model="numpy")
def occluded_range(scene, pk, o, d, tmax, out, i0, i1):
    """out[i] = ray i blocked within tmax[i], for i0 <= i < i1, OCCLUDE_PACKET rays a packet (pk)."""
    for p0 in range(i0, i1, OCCLUDE_PACKET):
        lanes = _fill_lanes(pk, OCCLUDE_PACKET, o, d, tmax, p0, i1)
        occluded_packet(scene, pk, lanes)
        for k in range(lanes):
            out[p0 + k] = blocked_lane(pk, k)


@njit(cache=True, error_model="numpy")
def intersect_range(scene, pk, o, d, tmax, t, prim, u, v, i0, i1):
    """Closest hits of rays i0 <= i < i1 within tmax[i] into t, prim, u, v, HIT_PACKET rays a
    packet (pk)."""
    for p0 in range(i0, i1, HIT_PACKET):
        lanes = _fill_lanes(pk, HIT_PACKET, o, d, tmax, p0, i1)
        intersect_packet(scene, pk, lanes)
        for k in range(lanes):
            t[p0 + k], prim[p0 + k], u[p0 + k], v[p0 + k] = hit_lane(pk, k)


@njit(cache=True, error_model="numpy", nogil=True)
def intersect_tiles(counter, bounds, scene, o, d, width, height, t, prim, u, v):
    """Closest hits (as intersect()) of the rays of a width x height image, o and d in pixel
    order, traced a TILE_W x TILE_H tile at a time as one packet; one worker of
    Tracer.run_parallel over the tiles (tiles()), row of tiles by row."""
    n = bounds[bounds.shape[0] - 1]
    tiles_x = (width + TILE_W - 1) // TILE_W
    ray, words, valid = packet(HIT_PACKET)
    w = HIT_PACKET
    pix = np.empty(w, np.int64)
    while True:
        b0, b1 = next_block(counter, bounds)
        if b0 >= n:
            return 0
        for tile in range(b0, b1):
            x0, y0 = (tile % tiles_x) * TILE_W, (tile // tiles_x) * TILE_H
            for k in range(w):
                x, y = x0 + (k % TILE_W), y0 + (k // TILE_W)
                if x < width and y < height:
                    p = y * width + x
                    valid[k] = -1
                else:
                    p = y0 * width + x0  # a lane left out: any ray, not traced
                    valid[k] = 0
                pix[k] = p
                set_lane(ray, words, w, k, o[p, 0], o[p, 1], o[p, 2], d[p, 0], d[p, 1], d[p, 2], MISS_T)
            _intersect_packet(valid.ctypes.data, scene, ray.ctypes.data, 0)
            for k in range(w):
                if valid[k] == 0:
                    continue
                p = pix[k]
                # hit_lane's reads, here without its packet tuple (one made per lane cost 55 ms a
                # 1280x720 frame on one thread: each holds references to the three arrays)
                if words[_GEOM * w + k] == INVALID:
                    t[p], prim[p], u[p], v[p] = MISS_T, -1, 0.0, 0.0
                else:
                    t[p], prim[p], u[p], v[p] = (ray[_T_FAR * w + k], np.int32(words[_PRIM * w + k]), ray[_U * w + k],
                                                 ray[_V * w + k])


def tiles(width: int, height: int) -> int:
    """How many packets intersect_tiles traces for a width x height image."""
    return ((width + TILE_W - 1) // TILE_W) * ((height + TILE_H - 1) // TILE_H)
