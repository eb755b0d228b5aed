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


def from_raster(channels: dict, camera, width: int, height: int) -> CpuGBuffer:
    """channels: the raster G-buffer as GL reads it, H x W x 4 float32, bottom row first."""
    from rt.kernels import covered_pixels, unpack_gbuffer

    face = channels["g_face"]
    idx = covered_pixels(face, height, width)
    m = idx.size
    s = Surface(*(np.empty((m, 3), np.float32) for _ in range(4)), np.empty(m, np.float32),
                np.empty(m, np.float32), np.empty((m, 3), np.float32))
    view = np.empty((width * height, 3), np.float32)
    depth = np.empty(width * height, np.float32)
    r, u, f = (x.astype(np.float64) for x in camera.basis())
    unpack_gbuffer(channels["g_position"], channels["g_normal"], channels["g_albedo"], channels["g_emissive"], face,
                   idx, camera.eye.astype(np.float64), r, u, f, float(np.tan(np.radians(camera.fov) / 2)),
                   width / height, s.p, s.n, s.ng, s.albedo, s.roughness, s.metallic, s.emissive, view, depth)
    covered = np.zeros(width * height, bool)
    covered[idx] = True
    return CpuGBuffer(width, height, camera.eye.astype(np.float32), view, covered, idx, s, depth)


def trace_primary(data: SceneData, tracer, camera, width: int, height: int) -> CpuGBuffer:
    o, d = camera.primary_rays(width, height)
    hits = tracer.intersect(o, d)
    covered = hits.hit
    idx = np.nonzero(covered)[0]
    sub = type(hits)(hits.t[idx], hits.prim[idx], hits.u[idx], hits.v[idx])
    s = data.surface(sub, d[idx], o[idx])
    _, _, fwd = camera.basis()
    depth = np.zeros(width * height, np.float32)
    depth[idx] = (s.p - camera.eye.astype(np.float32)) @ fwd.astype(np.float32)
    return CpuGBuffer(width, height, camera.eye.astype(np.float32), d, covered, idx, s, depth)
