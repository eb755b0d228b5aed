"""The G-buffer on the CPU, where the ray-traced passes start: read back from the raster
G-buffer (`gbuffer=raster`) or built from primary rays through Embree (`gbuffer=rt`)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rt.sampling import normalize
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


def view_dirs(camera, width: int, height: int) -> np.ndarray:
    _, d = camera.primary_rays(width, height)
    return d


def from_raster(channels: dict, camera, width: int, height: int) -> CpuGBuffer:
    """channels: H x W x 4 float32 arrays (row 0 = top) named like the raster G-buffer."""
    pos = channels["g_position"].reshape(-1, 4)
    nrm = channels["g_normal"].reshape(-1, 4)
    alb = channels["g_albedo"].reshape(-1, 4)
    emi = channels["g_emissive"].reshape(-1, 4)
    face = channels["g_face"].reshape(-1, 4)
    covered = face[:, 3] > 0
    idx = np.nonzero(covered)[0]
    s = Surface(np.ascontiguousarray(pos[idx, :3]), normalize(nrm[idx, :3]), normalize(face[idx, :3]),
                np.ascontiguousarray(alb[idx, :3]), nrm[idx, 3].copy(), alb[idx, 3].copy(),
                np.ascontiguousarray(emi[idx, :3]))
    vd = view_dirs(camera, width, height)
    # view directions through the actual surface points (exact for the raster G-buffer)
    vd[idx] = normalize(s.p - camera.eye.astype(np.float32))
    depth = np.where(covered, pos[:, 3], 0).astype(np.float32)
    return CpuGBuffer(width, height, camera.eye.astype(np.float32), vd, covered, idx, s, depth)


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
