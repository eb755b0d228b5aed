"""The G-buffer on the CPU, where the ray-traced passes start: read back from the raster
G-buffer (`gbuffer=raster`) or built from primary rays through Embree (`gbuffer=rt`)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rt.shading import SceneData, Surface


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

    @property
    def n(self) -> int:
        return self.width * self.height


def from_raster(packed: dict, camera, width: int, height: int) -> CpuGBuffer:
    """packed: the raster G-buffer packed for the CPU (app/raster/gbuffer_pack.py), as GL reads
    it: uint32 H x W x 4 ("geometry") and H x W x 2 ("material"), bottom row first."""
    from rt.kernels import covered_pixels, unpack_gbuffer

    geometry = np.ascontiguousarray(packed["geometry"])
    idx = covered_pixels(geometry, height, width)
    m = idx.size
    s = Surface(*(np.empty((m, 3), np.float32) for _ in range(4)), np.empty(m, np.float32),
                np.empty(m, np.float32), np.empty((m, 3), np.float32))
    view = np.empty((width * height, 3), np.float32)
    depth = np.empty(width * height, np.float32)
    r, u, f = (x.astype(np.float64) for x in camera.basis())
    unpack_gbuffer(geometry, geometry.view(np.float32), np.ascontiguousarray(packed["material"]), idx,
                   camera.eye.astype(np.float64), r, u, f, float(np.tan(np.radians(camera.fov) / 2)),
                   s.p, s.n, s.ng, s.albedo, s.roughness, s.metallic, s.emissive, view, depth)
    covered = np.zeros(width * height, bool)
    covered[idx] = True
    return CpuGBuffer(width, height, camera.eye.astype(np.float32), view, covered, idx, s, depth)


def trace_primary(data: SceneData, tracer, camera, width: int, height: int) -> CpuGBuffer:
    from rt.kernels import camera_rays

    r, u, f = (x.astype(np.float64) for x in camera.basis())
    o = np.empty((width * height, 3), np.float32)
    d = np.empty((width * height, 3), np.float32)
    camera_rays(camera.eye.astype(np.float64), r, u, f, float(np.tan(np.radians(camera.fov) / 2)), width, height, o, d)
    hits = tracer.intersect(o, d)
    covered = hits.hit
    idx = np.flatnonzero(covered)
    s = data.surface(hits, d, o, sel=idx)
    depth = np.zeros(width * height, np.float32)
    depth[idx] = hits.t[idx] * (d[idx] @ f.astype(np.float32))
    return CpuGBuffer(width, height, camera.eye.astype(np.float32), d, covered, idx, s, depth)
