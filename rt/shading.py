"""Hit shading and light sampling shared by every ray-traced pass.

Conventions (DESIGN.md): Lambertian albedo/pi; point/spot intensity I in W/sr with
irradiance I cos / d^2; sun irradiance E in W/m^2 with an optional angular radius; emissive
triangles emit radiance Le and are area lights: each emissive cluster (scenes/model.py) is one
light, and within it a triangle is picked with probability ~ area x power. The spot cone
falloff is glTF's (squared linear ramp in cos), as in shaders/forward.frag.

The per-point maths runs in compiled kernels (rt/kernels.py); this module owns the data and
the order of work: build rays, trace them in one batch, combine.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rt import kernels
from rt.tracer import Hits, Tracer

LUMA = np.array([0.2126, 0.7152, 0.0722], np.float32)
INV_PI = np.float32(1 / np.pi)
KINDS = {"point": 0, "spot": 1, "directional": 2}


@dataclass
class Surface:
    """Shading data at a set of points (hits or G-buffer pixels); normals face the viewer."""

    p: np.ndarray
    n: np.ndarray
    ng: np.ndarray
    albedo: np.ndarray
    roughness: np.ndarray
    metallic: np.ndarray
    emissive: np.ndarray

    def take(self, idx) -> Surface:
        return Surface(*(getattr(self, f)[idx] for f in self.__dataclass_fields__))

    def __len__(self) -> int:
        return self.p.shape[0]


class SceneData:
    """The scene in the flat arrays that the kernels shade with."""

    def __init__(self, scene):
        self.scene = scene
        f32 = lambda a: np.ascontiguousarray(a, np.float32)  # noqa: E731
        self.positions = f32(scene.positions)
        self.normals = f32(scene.normals)
        self.uvs = f32(scene.uvs)
        self.indices = np.ascontiguousarray(scene.indices, np.int32)
        self.material_ids = np.ascontiguousarray(scene.material_ids, np.int32)
        p0, p1, p2 = (self.positions[self.indices[:, k]] for k in range(3))
        cross = np.cross(p1 - p0, p2 - p0)
        length = np.sqrt(np.einsum("ij,ij->i", cross, cross))
        self.tri_area = f32(0.5 * length)
        self.face_normals = f32(cross / np.maximum(length, 1e-30)[:, None])
        mats = scene.materials
        self.base_color = f32([m.base_color[:3] for m in mats])
        self.roughness = f32([m.roughness for m in mats])
        self.metallic = f32([m.metallic for m in mats])
        self.emissive = f32([m.emissive for m in mats])
        # all base-colour textures in one flat texel array (offset, width, height per material)
        self.tex_offset = np.full(len(mats), -1, np.int64)
        self.tex_w = np.ones(len(mats), np.int64)
        self.tex_h = np.ones(len(mats), np.int64)
        chunks, offset = [np.zeros((1, 3), np.float32)], 1
        for k, m in enumerate(mats):
            if m.texture is not None:
                h, w = m.texture.shape[:2]
                self.tex_offset[k], self.tex_w[k], self.tex_h[k] = offset, w, h
                chunks.append(f32(m.texture[..., :3].reshape(-1, 3)))
                offset += h * w
        self.tex_data = np.ascontiguousarray(np.concatenate(chunks), np.float32)
        self.eps = np.float32(max(scene.diagonal * 2e-5, 1e-5))
        self.far = np.float32(max(scene.diagonal * 4.0, 1.0))
        self.lights = LightSet(scene, self)

    # -- surfaces ----------------------------------------------------------------------------
    def surface(self, hits: Hits, dirs: np.ndarray, origins: np.ndarray) -> Surface:
        """Shading data at the hits of rays (only rays that hit: filter first)."""
        n = hits.prim.shape[0]
        out = Surface(np.empty((n, 3), np.float32), np.empty((n, 3), np.float32), np.empty((n, 3), np.float32),
                      np.empty((n, 3), np.float32), np.empty(n, np.float32), np.empty(n, np.float32),
                      np.empty((n, 3), np.float32))
        if n:
            kernels.shade_hits(hits.prim, hits.u, hits.v, hits.t, np.ascontiguousarray(origins, np.float32),
                               np.ascontiguousarray(dirs, np.float32), self.positions, self.normals, self.uvs,
                               self.indices, self.material_ids, self.face_normals, self.base_color, self.roughness,
                               self.metallic, self.emissive, self.tex_offset, self.tex_w, self.tex_h, self.tex_data,
                               out.p, out.n, out.ng, out.albedo, out.roughness, out.metallic, out.emissive)
        return out

    def offset(self, s: Surface, toward: np.ndarray | None = None) -> np.ndarray:
        """Ray origins nudged off the surface (embreex has no tnear), on the side of `toward`."""
        ng = s.ng
        if toward is not None:
            side = np.einsum("ij,ij->i", ng, toward) < 0
            ng = np.where(side[:, None], -ng, ng)
        scale = self.eps * (1.0 + np.abs(s.p).max(axis=1, keepdims=True) * 1e-3)
        return (s.p + ng * scale).astype(np.float32)


class LightSet:
    """Analytic lights plus one light per emissive cluster, as flat arrays for the kernels."""

    def __init__(self, scene, data: SceneData):
        lights = scene.lights
        self.count_analytic = len(lights)
        f32 = lambda a, shape: np.ascontiguousarray(np.asarray(a, np.float32).reshape(shape))  # noqa: E731
        kind = np.array([KINDS[li.kind] for li in lights], np.int32)
        pos = f32([li.position for li in lights], (-1, 3))
        d = f32([li.direction for li in lights], (-1, 3))
        d = d / np.maximum(np.linalg.norm(d, axis=1, keepdims=True), 1e-20)
        rad = f32([li.radiance_scale for li in lights], (-1, 3))
        cos_out = f32(np.cos([li.outer_cone for li in lights]), (-1,))
        cos_in = f32(np.cos([li.inner_cone for li in lights]), (-1,))
        ang = f32([li.angular_radius for li in lights], (-1,))
        tris, keep, alias, pmf, le, double, start = [], [], [], [], [], [], [0]
        centre, radius, power = [], [], []
        for group in scene.emissive_clusters():
            e = data.emissive[data.material_ids[group]]
            weight = data.tri_area[group].astype(np.float64) * np.maximum(e @ LUMA, 0)
            total = weight.sum()
            if total <= 0:
                continue
            tris.append(group.astype(np.int64))
            k, a = kernels.alias_table(weight)
            keep.append(k)
            alias.append(a)
            pmf.append(weight / total)
            le.append(e)
            double.append([scene.materials[m].double_sided for m in data.material_ids[group]])
            start.append(start[-1] + len(group))
            pts = data.positions[data.indices[group]].reshape(-1, 3).astype(np.float64)
            c = pts.mean(0)
            centre.append(c)
            radius.append(np.linalg.norm(pts - c, axis=1).max())
            power.append(float(total))  # luminance of sum(Le A): ~ pi x emitted power / pi
        self.cluster_count = len(tris)
        self.cluster_centre = f32(centre, (-1, 3))
        self.cluster_radius = f32(radius, (-1,))
        self.cluster_power = f32(power, (-1,))
        self.cluster_tris = [t for t in tris]
        self.kernel_args = (
            kind, pos, d.astype(np.float32), rad, cos_out, cos_in, ang,
            np.asarray(start, np.int64),
            np.concatenate(tris) if tris else np.zeros(0, np.int64),
            np.concatenate(keep) if keep else np.zeros(0, np.float64),
            np.concatenate(alias).astype(np.int64) if alias else np.zeros(0, np.int64),
            f32(np.concatenate(pmf) if pmf else [], (-1,)),
            f32(np.concatenate(le) if le else [], (-1, 3)),
            np.concatenate(double).astype(np.bool_) if double else np.zeros(0, np.bool_),
            data.positions, data.indices, data.face_normals, data.tri_area, self.count_analytic)
        self.data = data

    def rays(self, k: int, s: Surface, c: slice, keys, dim: int, origin, direction, tmax, e) -> None:
        """Shadow rays to light k from the points in slice c (kernels specialised per light type)."""
        a = self.kernel_args
        eps, far = self.data.eps, self.data.far
        out = (origin[c], direction[c], tmax[c], e[c])
        if k < self.count_analytic:
            kernels.analytic_rays_chunk(k, s.p[c], s.n[c], s.ng[c], keys[c], dim, *a[:7], eps, far, *out)
        else:
            j = k - self.count_analytic
            kernels.cluster_rays_chunk(a[7][j], a[7][j + 1], s.p[c], s.n[c], s.ng[c], keys[c], dim, *a[8:18], eps,
                                       *out)

    @property
    def count(self) -> int:
        """Analytic lights, plus one per emissive cluster."""
        return self.count_analytic + self.cluster_count

    @property
    def has_emissive(self) -> bool:
        return self.cluster_count > 0


def _buffers(n: int):
    return (np.empty((n, 3), np.float32), np.empty((n, 3), np.float32), np.empty(n, np.float32),
            np.empty((n, 3), np.float32))


def _gather_light(tracer: Tracer, total, origin, direction, tmax, e, shadowed: bool, fill) -> None:
    """total += e for rays that reach their light. fill(c) writes the rays of chunk c into the
    buffers; with shadows, each tracing thread fills, compacts, traces and adds its own chunk."""
    n = total.shape[0]
    if not shadowed:
        fill(slice(0, n))
        total += e
        return
    live = {}

    def make(c):
        fill(c)
        idx = live[c.start] = kernels.compact(e[c], origin[c], direction[c], tmax[c])  # only rays carrying light
        m = idx.size
        return origin[c][:m], direction[c][:m], tmax[c][:m].copy()

    def use(c, blocked):
        kernels.add_unblocked_chunk(total[c], e[c], live[c.start], blocked)

    tracer.occlusion_pipeline(n, make, use)


def direct_all(data: SceneData, tracer: Tracer, s: Surface, rng, shadowed: bool = True) -> np.ndarray:
    """Irradiance x cos from every light: one shadow ray per light (a sample per emissive cluster)."""
    n = len(s)
    total = np.zeros((n, 3), np.float32)
    origin, direction, tmax, e = _buffers(n)
    for k in range(data.lights.count):
        dim = rng.reserve(3)
        if n:
            def fill(c, k=k, dim=dim):
                data.lights.rays(k, s, c, rng.key, dim, origin, direction, tmax, e)

            _gather_light(tracer, total, origin, direction, tmax, e, shadowed, fill)
    return total


def direct_one(data: SceneData, tracer: Tracer, s: Surface, rng, shadowed: bool = True) -> np.ndarray:
    """Irradiance x cos from ONE light per point, picked with probability ~ its estimated
    contribution there and divided by that probability: accumulates to direct_all."""
    lights = data.lights
    n = len(s)
    dim = rng.reserve(4)
    total = np.zeros((n, 3), np.float32)
    if lights.count == 0 or n == 0:
        return total
    origin, direction, tmax, e = _buffers(n)

    def fill(c):
        kernels.one_light_rays_chunk(s.p[c], s.n[c], s.ng[c], rng.key[c], dim, lights.kernel_args,
                                     lights.cluster_centre, lights.cluster_radius, lights.cluster_power, data.eps,
                                     data.far, origin[c], direction[c], tmax[c], e[c])

    _gather_light(tracer, total, origin, direction, tmax, e, shadowed, fill)
    return total


def hemisphere(data: SceneData, s: Surface, rng):
    """Cosine-weighted rays about the shading normals: (origins, directions, above-surface mask)."""
    n = len(s)
    origin = np.empty((n, 3), np.float32)
    direction = np.empty((n, 3), np.float32)
    valid = np.empty(n, np.bool_)
    dim = rng.reserve(2)
    if n:
        kernels.hemisphere_rays(s.p, s.n, s.ng, rng.key, dim, data.eps, origin, direction, valid)
    return origin, direction, valid


def fresnel_schlick(s: Surface, view_dir: np.ndarray) -> np.ndarray:
    """Schlick's Fresnel with F0 = 0.04 for dielectrics and the albedo for metals."""
    f0 = 0.04 * (1 - s.metallic[:, None]) + s.albedo * s.metallic[:, None]
    cos = np.clip(-np.einsum("ij,ij->i", s.n, view_dir), 0, 1)
    return (f0 + (1 - f0) * ((1 - cos) ** 5)[:, None]).astype(np.float32)


def trace_from(data: SceneData, tracer: Tracer, s: Surface, dirs: np.ndarray, origins: np.ndarray | None = None):
    """Trace rays leaving surface points; returns (hit index, surfaces at the hits, miss index)."""
    o = data.offset(s, dirs) if origins is None else origins
    hits = tracer.intersect(o, dirs)
    hit = np.flatnonzero(hits.prim >= 0)
    miss = np.flatnonzero(hits.prim < 0)
    sub = Hits(hits.t[hit], hits.prim[hit], hits.u[hit], hits.v[hit])
    return hit, data.surface(sub, dirs[hit], o[hit]), miss


def mirror(d: np.ndarray, s: Surface) -> np.ndarray:
    """Mirror direction about the shading normal; about the face normal where that would
    send the ray into the surface."""
    r = d - 2 * np.einsum("ij,ij->i", d, s.n)[:, None] * s.n
    bad = np.einsum("ij,ij->i", r, s.ng) <= 0
    if bad.any():
        rg = d - 2 * np.einsum("ij,ij->i", d, s.ng)[:, None] * s.ng
        r = np.where(bad[:, None], rg, r)
    return r.astype(np.float32)
