"""The G-buffer on the CPU, where the ray-traced passes start: read back from the raster
G-buffer (`gbuffer=raster`) or built from primary rays through Embree (`gbuffer=rt`)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rt.embree.shading import SceneData, Surface


@dataclass
class CpuGBuffer:
    width: int
    height: int
    eye: np.ndarray
    view_dir: np.ndarray  # (N,3) unit, camera -> pixel, every pixel
    covered: np.ndarray  # (N,) bool
    index: np.ndarray  # (M,) pixel ids of covered pixels
    surface: Surface  # (M,) primary hits
    depth: np.ndarray  # (N,) linear depth, 0 where uncovered
    soa: np.ndarray | None = None  # (9, M) the surface's p, n, ng as rows (Surface.soa), for the ray generators

    @property
    def n(self) -> int:
        return self.width * self.height


def from_raster(packed: dict, camera, width: int, height: int, reuse: bool = False,
                jitter=(0.0, 0.0)) -> CpuGBuffer:
    """packed: the raster G-buffer packed for the CPU (app/raster/gbuffer_pack.py), as GL reads
    it: uint32 H x W x 4 ("geometry" and "material"), bottom row first.
    reuse: build it in this thread's scratch buffers (rt/embree/scratch.py), valid until the thread's
    next call: fresh arrays are ~80 MB a frame at 1280x720, and their page faults cost more than
    the unpacking. jitter: the frame's subpixel offset (pixels, right and down), which the raster's
    projection had."""
    from rt.embree import scratch
    from rt.embree.kernels import covered_pixels, unpack_gbuffer

    n = width * height

    def new(name: str, shape: tuple, dtype=np.float32) -> np.ndarray:
        return scratch.buffer("gbuffer." + name, shape, dtype) if reuse else np.empty(shape, dtype)

    geometry = np.ascontiguousarray(packed["geometry"])
    idx = new("index", (n,), np.int64)
    row_start = new("rows", (height + 1,), np.int64)
    m = covered_pixels(geometry, height, width, idx, row_start)
    idx = idx[:m]
    s = Surface(*(new(f, (m, 3)) for f in ("p", "n", "ng", "albedo")), new("roughness", (m,)),
                new("metallic", (m,)), new("emissive", (m, 3)))
    view = new("view", (n, 3))
    depth = new("depth", (n,))
    covered = new("covered", (n,), np.bool_)
    soa = new("soa", (9, m))
    r, u, f = (x.astype(np.float64) for x in camera.basis())
    unpack_gbuffer((geometry, geometry.view(np.float32), np.ascontiguousarray(packed["material"])), (idx, row_start),
                   (camera.eye.astype(np.float64), r, u, f, float(np.tan(np.radians(camera.fov) / 2)),
                    np.asarray(jitter, np.float64)), s.arrays(), (view, depth, covered), soa)
    return CpuGBuffer(width, height, camera.eye.astype(np.float32), view, covered, idx, s, depth, soa)


def trace_primary(data: SceneData, tracer, camera, width: int, height: int, reuse: bool = False,
                  jitter=(0.0, 0.0)) -> CpuGBuffer:
    """The G-buffer from primary rays through Embree (`gbuffer=rt`); reuse and jitter as from_raster."""
    from rt.embree import scratch
    from rt.embree.kernels import camera_rays, primary_pixels
    from rt.embree.raygen import surface_soa
    from rt.embree.shading import empty_surface

    n = width * height
    r, u, f = (x.astype(np.float64) for x in camera.basis())
    o = scratch.buffer("gbuffer.rt.o", (n, 3)) if reuse else np.empty((n, 3), np.float32)
    d = scratch.buffer("gbuffer.rt.d", (n, 3)) if reuse else np.empty((n, 3), np.float32)
    camera_rays(camera.eye.astype(np.float64), r, u, f, float(np.tan(np.radians(camera.fov) / 2)),
                np.asarray(jitter, np.float64), width, height, o, d)
    hits = tracer.intersect_image(o, d, width, height)
    if data.has_single_sided:
        cull_back_faces(data, tracer, o, d, hits)
    covered = scratch.buffer("gbuffer.rt.covered", (n,), np.bool_) if reuse else np.empty(n, np.bool_)
    idx = scratch.buffer("gbuffer.rt.index", (n,), np.int64) if reuse else np.empty(n, np.int64)
    depth = scratch.buffer("gbuffer.rt.depth", (n,)) if reuse else np.empty(n, np.float32)
    idx = idx[:primary_pixels(hits.t, hits.prim, d, f.astype(np.float32), covered, idx, depth)]
    s = empty_surface(len(idx), "gbuffer.rt.s" if reuse else None)
    soa = scratch.buffer("gbuffer.rt.soa", (9, len(idx))) if reuse else np.empty((9, len(idx)), np.float32)

    def shade(c: slice, _) -> None:
        """A chunk's hits shaded, then its rows for the ray generators (Surface.soa) while they
        are in the cache. On the tracer's threads, where surface() runs the serial kernel the
        passes link anyway: its parallel loop would be one more kernel to compile before a
        first frame."""
        part = data.surface(hits, d, o, sel=idx[c], out=s.take(c))
        surface_soa(part.p, part.n, part.ng, soa[:, c])

    tracer.map_chunks(len(idx), shade)
    return CpuGBuffer(width, height, camera.eye.astype(np.float32), d, covered, idx, s, depth, soa)


BACK_FACE_LAYERS = 64  # single-sided back faces a primary ray passes at most (trace.slang: ALPHA_LAYERS)


def cull_back_faces(arrays, tracer, o: np.ndarray, d: np.ndarray, hits) -> None:
    """Primary rays that hit the back of a single-sided triangle (glTF doubleSided false: seen
    from the side its face normal leaves, counter-clockwise) go on from just beyond it
    (primary.slang does the same); hits is updated in place."""
    for _ in range(BACK_FACE_LAYERS):
        rows = np.flatnonzero(hits.prim >= 0)
        tri = hits.prim[rows]
        back = arrays.single_sided[arrays.material_ids[tri]]
        back &= np.einsum("ij,ij->i", d[rows], arrays.face_normals[tri]) > 0
        rows = rows[back]
        if not len(rows):
            return
        step = hits.t[rows] * np.float32(1.0 + 1e-6) + np.float32(1e-7)
        again = tracer.intersect(o[rows] + d[rows] * step[:, None], d[rows])
        hits.prim[rows], hits.u[rows], hits.v[rows] = again.prim, again.u, again.v
        hits.t[rows] = np.where(again.prim >= 0, step + again.t, again.t)
