"""Vectorised mesh construction for the built-in scenes.

Primitives are built once in local space and instanced with (K,4,4) transforms in one
NumPy call, so scenes with millions of leaf triangles build in well under a second.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from scenes.model import Environment, Light, Material, Scene, View


@dataclass
class Mesh:
    positions: np.ndarray  # (V,3)
    normals: np.ndarray  # (V,3)
    uvs: np.ndarray  # (V,2)
    indices: np.ndarray  # (T,3)


# -- transforms ----------------------------------------------------------------------------
def trs(translate=(0, 0, 0), rotate_y=0.0, scale=(1, 1, 1), rotate_x=0.0, rotate_z=0.0) -> np.ndarray:
    """One 4x4 transform: scale, then rotate about X, Z, Y (radians), then translate."""
    return trs_many(np.array([translate], float), np.array([rotate_y], float), np.array([scale], float),
                    np.array([rotate_x], float), np.array([rotate_z], float))[0]


def trs_many(t, ry=None, s=None, rx=None, rz=None) -> np.ndarray:
    """(K,4,4) transforms from per-instance translation, Y/X/Z rotation and scale."""
    t = np.asarray(t, float).reshape(-1, 3)
    k = t.shape[0]
    ry = np.zeros(k) if ry is None else np.broadcast_to(np.asarray(ry, float), (k,))
    rx = np.zeros(k) if rx is None else np.broadcast_to(np.asarray(rx, float), (k,))
    rz = np.zeros(k) if rz is None else np.broadcast_to(np.asarray(rz, float), (k,))
    s = np.ones((k, 3)) if s is None else np.broadcast_to(np.asarray(s, float), (k, 3))

    def rot(axis, a):
        c, n = np.cos(a), np.sin(a)
        m = np.zeros((k, 3, 3))
        i, j = [(1, 2), (0, 2), (0, 1)][axis]
        m[:, axis, axis] = 1
        m[:, i, i] = c
        m[:, j, j] = c
        sign = -1 if axis == 1 else 1
        m[:, i, j] = -n * sign
        m[:, j, i] = n * sign
        return m

    r = rot(1, ry) @ rot(2, rz) @ rot(0, rx)
    out = np.zeros((k, 4, 4))
    out[:, :3, :3] = r * s[:, None, :]
    out[:, :3, 3] = t
    out[:, 3, 3] = 1
    return out


# -- primitives (local space) -----------------------------------------------------------------
def box() -> Mesh:
    """Unit cube [-0.5,0.5]^3 with flat faces."""
    faces = []
    for axis in range(3):
        for sign in (-1.0, 1.0):
            n = np.zeros(3)
            n[axis] = sign
            u = np.zeros(3)
            v = np.zeros(3)
            u[(axis + 1) % 3] = 1
            v[(axis + 2) % 3] = 1
            if sign < 0:
                u, v = v, u
            c = n * 0.5
            quad = np.array([c - u / 2 - v / 2, c + u / 2 - v / 2, c + u / 2 + v / 2, c - u / 2 + v / 2])
            faces.append((quad, n))
    pos = np.concatenate([q for q, _ in faces])
    nrm = np.repeat(np.array([n for _, n in faces]), 4, axis=0)
    uv = np.tile([[0, 0], [1, 0], [1, 1], [0, 1]], (6, 1))
    idx = np.concatenate([np.array([[0, 1, 2], [0, 2, 3]]) + 4 * f for f in range(6)])
    return Mesh(pos, nrm, uv.astype(float), idx)


def grid(nx: int = 1, nz: int = 1, uv_scale: float = 1.0) -> Mesh:
    """Plane [-0.5,0.5]^2 in XZ facing +Y, subdivided nx x nz (for triangle budgets)."""
    xs = np.linspace(-0.5, 0.5, nx + 1)
    zs = np.linspace(-0.5, 0.5, nz + 1)
    gx, gz = np.meshgrid(xs, zs, indexing="xy")
    pos = np.stack([gx.ravel(), np.zeros(gx.size), gz.ravel()], 1)
    uv = np.stack([(gx.ravel() + 0.5), (gz.ravel() + 0.5)], 1) * uv_scale
    i = np.arange(nz)[:, None] * (nx + 1) + np.arange(nx)[None, :]
    i = i.ravel()
    a, b, c, d = i, i + 1, i + nx + 2, i + nx + 1
    idx = np.concatenate([np.stack([a, d, c], 1), np.stack([a, c, b], 1)])
    nrm = np.tile([0.0, 1.0, 0.0], (pos.shape[0], 1))
    return Mesh(pos, nrm, uv, idx)


def lathe(profile, segments: int = 16, smooth: bool = True) -> Mesh:
    """Surface of revolution about +Y from a (radius, y) profile, bottom to top."""
    prof = np.asarray(profile, float)
    m = prof.shape[0]
    ang = np.linspace(0, 2 * np.pi, segments + 1)
    r, y = prof[:, 0], prof[:, 1]
    # profile tangent -> outward normal (dr, dy) rotated
    dr = np.gradient(r) if m > 1 else np.zeros(1)
    dy = np.gradient(y) if m > 1 else np.ones(1)
    nr, ny = dy, -dr
    ln = np.hypot(nr, ny)
    ln[ln == 0] = 1
    nr, ny = nr / ln, ny / ln
    ca, sa = np.cos(ang), np.sin(ang)
    pos = np.stack([r[:, None] * ca[None], np.repeat(y[:, None], segments + 1, 1), r[:, None] * sa[None]], -1)
    nrm = np.stack([nr[:, None] * ca[None], np.repeat(ny[:, None], segments + 1, 1), nr[:, None] * sa[None]], -1)
    uv = np.stack(np.meshgrid(ang / (2 * np.pi), np.linspace(0, 1, m)), -1)
    i = (np.arange(m - 1)[:, None] * (segments + 1) + np.arange(segments)[None]).ravel()
    a, b, c, d = i, i + 1, i + segments + 2, i + segments + 1
    idx = np.concatenate([np.stack([a, c, b], 1), np.stack([a, d, c], 1)])
    mesh = Mesh(pos.reshape(-1, 3), nrm.reshape(-1, 3), uv.reshape(-1, 2), idx)
    # drop triangles that collapsed on the axis (radius 0 at both ends of an edge)
    p = mesh.positions[mesh.indices]
    area = np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)
    mesh.indices = mesh.indices[area > 1e-12]
    return mesh


def disc(segments: int = 16, up: bool = True) -> Mesh:
    """Unit disc in XZ at y=0 facing +Y (or -Y)."""
    ang = np.linspace(0, 2 * np.pi, segments, endpoint=False)
    pos = np.concatenate([[[0, 0, 0]], np.stack([np.cos(ang), np.zeros(segments), np.sin(ang)], 1)])
    k = np.arange(segments)
    idx = np.stack([np.zeros(segments, int), 1 + (k + 1) % segments, 1 + k], 1)
    ny = 1.0 if up else -1.0
    if not up:
        idx = idx[:, [0, 2, 1]]
    nrm = np.tile([0, ny, 0], (segments + 1, 1))
    uv = pos[:, [0, 2]] * 0.5 + 0.5
    return Mesh(pos.astype(float), nrm.astype(float), uv, idx)


def cylinder(segments: int = 16, caps: bool = True) -> Mesh:
    """Radius 1, y in [0,1], sharp cap edges."""
    side = lathe([(1, 0), (1, 1)], segments)
    side.normals[:, 1] = 0
    side.normals /= np.linalg.norm(side.normals, axis=1, keepdims=True)
    if not caps:
        return side
    top = transform(disc(segments, True), trs((0, 1, 0)))
    bottom = disc(segments, False)
    return merge([side, top, bottom])


def sphere(rings: int = 8, segments: int = 16) -> Mesh:
    t = np.linspace(0, np.pi, rings + 1)
    return lathe(np.stack([np.sin(t), -np.cos(t)], 1), segments)


def quad() -> Mesh:
    """Unit quad in XY facing +Z, [-0.5,0.5]^2 (signs, screens, leaves)."""
    pos = np.array([[-0.5, -0.5, 0], [0.5, -0.5, 0], [0.5, 0.5, 0], [-0.5, 0.5, 0]], float)
    return Mesh(pos, np.tile([0, 0, 1.0], (4, 1)), np.array([[0, 0], [1, 0], [1, 1], [0, 1]], float),
                np.array([[0, 1, 2], [0, 2, 3]]))


def normal_matrix(lin: np.ndarray) -> np.ndarray:
    """(K,3,3) matrices that carry normals: the cofactor matrix (det x inverse-transpose),
    which also exists for flattened (singular) scales; sign-corrected for mirrors."""
    r0, r1, r2 = lin[..., 0, :], lin[..., 1, :], lin[..., 2, :]
    cof = np.stack([np.cross(r1, r2), np.cross(r2, r0), np.cross(r0, r1)], axis=-2)
    sign = np.where(np.linalg.det(lin) < 0, -1.0, 1.0)
    return cof * sign[..., None, None]


def merge(meshes) -> Mesh:
    offs = np.cumsum([0] + [m.positions.shape[0] for m in meshes])
    return Mesh(np.concatenate([m.positions for m in meshes]), np.concatenate([m.normals for m in meshes]),
                np.concatenate([m.uvs for m in meshes]),
                np.concatenate([m.indices + o for m, o in zip(meshes, offs, strict=False)]))


def transform(mesh: Mesh, m4: np.ndarray) -> Mesh:
    p = mesh.positions @ m4[:3, :3].T + m4[:3, 3]
    n = mesh.normals @ normal_matrix(m4[:3, :3]).T
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-12)
    return Mesh(p, n, mesh.uvs.copy(), mesh.indices.copy())


# -- the builder -----------------------------------------------------------------------------
class SceneBuilder:
    """Collects instanced primitives, materials, lights and views into a Scene."""

    def __init__(self, name: str, seed: int = 0):
        self.name = name
        self.rng = np.random.default_rng(seed)
        self._parts: list[tuple] = []
        self.materials: list[Material] = []
        self._mat_index: dict[str, int] = {}
        self.lights: list[Light] = []
        self.views: dict[str, View] = {}
        self.environment = Environment()
        self.ambient = (0.0, 0.0, 0.0)

    def material(self, name: str, color=(0.8, 0.8, 0.8), roughness=0.6, metallic=0.0, emissive=(0, 0, 0),
                 texture=None) -> str:
        if name not in self._mat_index:
            rgba = tuple(float(c) for c in color) + ((1.0,) if len(color) == 3 else ())
            self._mat_index[name] = len(self.materials)
            self.materials.append(Material(name, rgba, texture, float(roughness), float(metallic),
                                           tuple(float(e) for e in emissive)))
        return name

    def add(self, mesh: Mesh, material: str, transforms) -> None:
        """Add one instance (4,4) or many (K,4,4) of mesh."""
        mats = np.asarray(transforms, float).reshape(-1, 4, 4)
        if mats.shape[0] == 0:
            return
        lin = mats[:, :3, :3]
        pos = np.matmul(mesh.positions[None], lin.transpose(0, 2, 1)) + mats[:, None, :3, 3]
        nrm = np.matmul(mesh.normals[None], normal_matrix(lin).transpose(0, 2, 1))
        nrm /= np.maximum(np.linalg.norm(nrm, axis=2, keepdims=True), 1e-12)
        k, v = pos.shape[:2]
        flip = np.linalg.det(lin) < 0  # mirrored instances keep counter-clockwise winding
        idx = np.broadcast_to(mesh.indices, (k,) + mesh.indices.shape).copy()
        idx[flip] = idx[flip][:, :, [0, 2, 1]]
        idx += (np.arange(k) * v)[:, None, None]
        uv = np.broadcast_to(mesh.uvs, (k, v, 2))
        self._parts.append((pos.reshape(-1, 3), nrm.reshape(-1, 3), uv.reshape(-1, 2), idx.reshape(-1, 3),
                            self._mat_index[material]))

    def box(self, material: str, lo, hi) -> None:
        """Axis-aligned box between two corners (the common case for architecture)."""
        lo, hi = np.asarray(lo, float), np.asarray(hi, float)
        self.add(box(), material, trs((lo + hi) / 2, 0.0, hi - lo))

    def light(self, **kw) -> None:
        self.lights.append(Light(**kw))

    def view(self, name, eye, target, fov=60.0) -> None:
        self.views[name] = View(name, tuple(map(float, eye)), tuple(map(float, target)), (0.0, 1.0, 0.0),
                                float(fov))

    def build(self) -> Scene:
        pos, nrm, uv, idx, mid = [], [], [], [], []
        offset = 0
        for p, n, t, i, m in self._parts:
            pos.append(p)
            nrm.append(n)
            uv.append(t)
            idx.append(i + offset)
            mid.append(np.full(i.shape[0], m, np.int32))
            offset += p.shape[0]
        scene = Scene(self.name, np.concatenate(pos).astype(np.float32), np.concatenate(nrm).astype(np.float32),
                      np.concatenate(uv).astype(np.float32), np.concatenate(idx).astype(np.int32),
                      np.concatenate(mid), self.materials, self.lights, self.environment, self.views, "builtin",
                      self.ambient)
        scene.validate()
        return scene
