"""Hit shading and light sampling shared by every ray-traced pass.

Conventions (DESIGN.md): Lambertian albedo/pi; point/spot intensity I in W/sr with
irradiance I cos / d^2; sun irradiance E in W/m^2 with an optional angular radius; emissive
triangles emit radiance Le and are area lights, picked with probability ~ area x power.
The spot cone falloff is glTF's (squared linear ramp in cos), as in shaders/forward.frag.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rt.sampling import normalize, uniform_cone
from rt.tracer import Hits, Tracer

LUMA = np.array([0.2126, 0.7152, 0.0722], np.float32)
INV_PI = np.float32(1 / np.pi)
KINDS = {"point": 0, "spot": 1, "directional": 2}
MAX_WEIGHTED_LIGHTS = 64  # up to this many lights, one-light picks weigh every light's contribution
WEIGHT_BLOCK = 32768


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
    """The scene in the flat arrays that the passes shade with."""

    def __init__(self, scene):
        self.scene = scene
        self.positions = scene.positions
        self.normals = scene.normals
        self.uvs = scene.uvs
        self.indices = scene.indices
        self.material_ids = scene.material_ids
        p = scene.positions[scene.indices]
        cross = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
        length = np.linalg.norm(cross, axis=1)
        self.tri_area = (0.5 * length).astype(np.float32)
        self.face_normals = (cross / np.maximum(length, 1e-30)[:, None]).astype(np.float32)
        mats = scene.materials
        self.base_color = np.array([m.base_color[:3] for m in mats], np.float32)
        self.roughness = np.array([m.roughness for m in mats], np.float32)
        self.metallic = np.array([m.metallic for m in mats], np.float32)
        self.emissive = np.array([m.emissive for m in mats], np.float32)
        self.textures = {k: m.texture.astype(np.float32) for k, m in enumerate(mats) if m.texture is not None}
        self.eps = np.float32(max(scene.diagonal * 2e-5, 1e-5))
        self.far = np.float32(max(scene.diagonal * 4.0, 1.0))
        self.lights = LightSet(scene, self)

    # -- surfaces ----------------------------------------------------------------------------
    def surface(self, hits: Hits, dirs: np.ndarray, origins: np.ndarray) -> Surface:
        """Shading data at the hits of rays (only rays that hit: filter first)."""
        prim = hits.prim
        tri = self.indices[prim]
        w1, w2 = hits.u[:, None], hits.v[:, None]
        w0 = 1.0 - w1 - w2
        p = (origins + dirs * hits.t[:, None]).astype(np.float32)
        ng = self.face_normals[prim]
        flip = np.einsum("ij,ij->i", ng, dirs) > 0
        ng = np.where(flip[:, None], -ng, ng)
        n = normalize(w0 * self.normals[tri[:, 0]] + w1 * self.normals[tri[:, 1]] + w2 * self.normals[tri[:, 2]])
        n = np.where((np.einsum("ij,ij->i", n, ng) < 0)[:, None], -n, n)
        uv = w0 * self.uvs[tri[:, 0]] + w1 * self.uvs[tri[:, 1]] + w2 * self.uvs[tri[:, 2]]
        mat = self.material_ids[prim]
        albedo = self.base_color[mat].copy()
        for k, tex in self.textures.items():
            sel = np.nonzero(mat == k)[0]
            if sel.size:
                albedo[sel] *= sample_texture(tex, uv[sel])
        return Surface(p, n.astype(np.float32), ng, albedo, self.roughness[mat], self.metallic[mat], self.emissive[mat])

    def offset(self, s: Surface, toward: np.ndarray | None = None) -> np.ndarray:
        """Ray origins nudged off the surface (embreex has no tnear), on the side of `toward`."""
        ng = s.ng
        if toward is not None:
            side = np.einsum("ij,ij->i", ng, toward) < 0
            ng = np.where(side[:, None], -ng, ng)
        scale = self.eps * (1.0 + np.abs(s.p).max(axis=1, keepdims=True) * 1e-3)
        return (s.p + ng * scale).astype(np.float32)


def sample_texture(tex: np.ndarray, uv: np.ndarray) -> np.ndarray:
    """Bilinear lookup with repeat wrapping; uv (0,0) is the image's top-left (glTF)."""
    h, w = tex.shape[:2]
    x = uv[:, 0] * w - 0.5
    y = uv[:, 1] * h - 0.5
    x0 = np.floor(x)
    y0 = np.floor(y)
    fx, fy = (x - x0)[:, None], (y - y0)[:, None]
    x0 = x0.astype(np.int64) % w
    y0 = y0.astype(np.int64) % h
    x1, y1 = (x0 + 1) % w, (y0 + 1) % h
    top = tex[y0, x0, :3] * (1 - fx) + tex[y0, x1, :3] * fx
    bottom = tex[y1, x0, :3] * (1 - fx) + tex[y1, x1, :3] * fx
    return (top * (1 - fy) + bottom * fy).astype(np.float32)


class LightSet:
    """Analytic lights plus one 'emissive' pseudo-light that samples emitting triangles."""

    def __init__(self, scene, data: SceneData):
        self.data = data
        lights = scene.lights
        self.count_analytic = len(lights)
        self.kind = np.array([KINDS[li.kind] for li in lights], np.int32)
        self.position = np.array([li.position for li in lights], np.float32).reshape(-1, 3)
        d = np.array([li.direction for li in lights], np.float32).reshape(-1, 3)
        self.direction = normalize(d) if len(lights) else d
        self.radiance = np.array([li.radiance_scale for li in lights], np.float32).reshape(-1, 3)
        self.cos_outer = np.cos([li.outer_cone for li in lights]).astype(np.float32)
        self.cos_inner = np.cos([li.inner_cone for li in lights]).astype(np.float32)
        self.angular_radius = np.array([li.angular_radius for li in lights], np.float32)
        # each emissive cluster is one light; within it a triangle is picked ~ area x power
        self.clusters = []
        for tris in scene.emissive_clusters():
            le = data.emissive[data.material_ids[tris]]
            weight = data.tri_area[tris].astype(np.float64) * np.maximum(le @ LUMA, 0)
            total = weight.sum()
            if total <= 0:
                continue
            self.clusters.append({
                "tris": tris, "le": le, "cdf": np.cumsum(weight) / total, "pmf": (weight / total).astype(np.float32),
                "double": np.array([scene.materials[m].double_sided for m in data.material_ids[tris]]),
                "power": float(total * np.pi),
            })
        self.has_emissive = bool(self.clusters)

    @property
    def count(self) -> int:
        """Analytic lights, plus one per emissive cluster."""
        return self.count_analytic + len(self.clusters)

    def sample(self, k: int, s: Surface, u: np.ndarray):
        """Light k seen from surface points. Returns (dir, dist, E): unit direction to the light,
        the distance to test for occlusion, and irradiance x cos at the surface (N,3), i.e.
        radiance out = albedo/pi * E for a diffuse surface when unoccluded."""
        if k >= self.count_analytic:
            return self._sample_emissive(self.clusters[k - self.count_analytic], s, u)
        kind = self.kind[k]
        n = len(s)
        if kind == 2:  # sun
            axis = np.broadcast_to(-self.direction[k], (n, 3)).astype(np.float32)
            r = float(self.angular_radius[k])
            ldir = uniform_cone(axis, float(np.cos(r)), u) if r > 0 else axis.copy()
            e = np.broadcast_to(self.radiance[k], (n, 3))
            dist = np.full(n, self.data.far, np.float32)
        else:
            d = self.position[k] - s.p
            dist2 = np.maximum(np.einsum("ij,ij->i", d, d), 1e-12)
            dist = np.sqrt(dist2)
            ldir = (d / dist[:, None]).astype(np.float32)
            atten = 1.0 / dist2
            if kind == 1:  # spot: glTF's squared linear ramp between the cone angles
                cd = -(ldir @ self.direction[k])
                t = np.clip((cd - self.cos_outer[k]) / max(self.cos_inner[k] - self.cos_outer[k], 1e-3), 0, 1)
                atten = atten * t * t
            e = self.radiance[k][None] * atten[:, None]
        cos = np.einsum("ij,ij->i", s.n, ldir)
        front = (cos > 0) & (np.einsum("ij,ij->i", s.ng, ldir) > 0)
        e = np.where(front[:, None], e * np.maximum(cos, 0)[:, None], 0).astype(np.float32)
        return ldir, dist.astype(np.float32), e

    def _sample_emissive(self, c: dict, s: Surface, u: np.ndarray):
        data = self.data
        pick = np.minimum(np.searchsorted(c["cdf"], u[:, 0], side="right"), len(c["tris"]) - 1)
        tri = c["tris"][pick]
        su = np.sqrt(u[:, 1])  # uniform point on the triangle
        v = data.positions[data.indices[tri]]
        q = v[:, 0] * (1 - su)[:, None] + v[:, 1] * (su * (1 - u[:, 2]))[:, None] + v[:, 2] * (su * u[:, 2])[:, None]
        d = q - s.p
        dist2 = np.maximum(np.einsum("ij,ij->i", d, d), 1e-12)
        dist = np.sqrt(dist2)
        ldir = (d / dist[:, None]).astype(np.float32)
        cos_l = -np.einsum("ij,ij->i", data.face_normals[tri], ldir)
        cos_l = np.where(c["double"][pick], np.abs(cos_l), np.maximum(cos_l, 0))
        cos_s = np.einsum("ij,ij->i", s.n, ldir)
        front = (cos_s > 0) & (np.einsum("ij,ij->i", s.ng, ldir) > 0)
        pdf_area = c["pmf"][pick] / np.maximum(data.tri_area[tri], 1e-20)
        g = cos_l * np.maximum(cos_s, 0) / dist2 / np.maximum(pdf_area, 1e-20)
        e = np.where(front[:, None], c["le"][pick] * g[:, None], 0).astype(np.float32)
        # stop short of the emitter itself
        return ldir, (dist * (1 - 1e-4) - data.eps).astype(np.float32), e

    def power_weights(self) -> np.ndarray:
        """Rough emitted power per light (for picking among many lights)."""
        w = []
        for k in range(self.count_analytic):
            lum = float(self.radiance[k] @ LUMA)
            w.append(lum * (4 * np.pi if self.kind[k] != 2 else self.data.scene.diagonal ** 2))
        w += [c["power"] for c in self.clusters]
        w = np.asarray(w, np.float64)
        return w / w.sum() if w.sum() > 0 else np.full(len(w), 1.0 / max(len(w), 1))


def visible(data: SceneData, tracer: Tracer, s: Surface, ldir: np.ndarray, dist: np.ndarray,
            active: np.ndarray | None = None) -> np.ndarray:
    """(N,) float32 visibility of the light along ldir; only `active` rays are traced."""
    vis = np.zeros(len(s), np.float32)
    idx = np.nonzero(active)[0] if active is not None else np.arange(len(s))
    if idx.size:
        sub = s.take(idx)
        o = data.offset(sub, ldir[idx])
        blocked = tracer.occluded(o, ldir[idx], np.maximum(dist[idx] - data.eps, data.eps))
        vis[idx] = (~blocked).astype(np.float32)
    return vis


def direct_all(data: SceneData, tracer: Tracer, s: Surface, rng, shadowed: bool = True) -> np.ndarray:
    """Irradiance x cos from every light: one shadow ray per analytic light and one emissive sample."""
    total = np.zeros((len(s), 3), np.float32)
    for k in range(data.lights.count):
        u = rng.next(3)
        ldir, dist, e = data.lights.sample(k, s, u)
        if shadowed:
            e = e * visible(data, tracer, s, ldir, dist, e.max(axis=1) > 0)[:, None]
        total += e
    return total


def direct_one(data: SceneData, tracer: Tracer, s: Surface, rng, shadowed: bool = True) -> np.ndarray:
    """Irradiance x cos from ONE light per point, chosen with probability ~ its unshadowed
    contribution there (~ its power when there are very many lights); divided by that
    probability, so the mean over frames equals direct_all."""
    lights = data.lights
    n, count = len(s), lights.count
    if count == 0 or n == 0:
        return np.zeros((n, 3), np.float32)
    u_pick = rng.next(1)[:, 0]
    u = rng.next(3)
    ldir = np.zeros((n, 3), np.float32)
    dist = np.zeros(n, np.float32)
    e = np.zeros((n, 3), np.float32)
    prob = np.zeros(n, np.float32)
    if count <= MAX_WEIGHTED_LIGHTS:
        for lo in range(0, n, WEIGHT_BLOCK):  # blocks bound the (points x lights) memory
            blk = slice(lo, min(n, lo + WEIGHT_BLOCK))
            sb = s.take(blk)
            samples = [lights.sample(k, sb, u[blk]) for k in range(count)]
            w = np.stack([x[2] @ LUMA for x in samples], 1)
            wsum = w.sum(1)
            cdf = np.cumsum(w, 1) / np.maximum(wsum, 1e-30)[:, None]
            pick = np.minimum((cdf < u_pick[blk, None]).sum(1), count - 1)
            rows = np.arange(pick.size)
            prob[blk] = w[rows, pick] / np.maximum(wsum, 1e-30)
            ldir[blk] = np.stack([x[0] for x in samples], 1)[rows, pick]
            dist[blk] = np.stack([x[1] for x in samples], 1)[rows, pick]
            e[blk] = np.stack([x[2] for x in samples], 1)[rows, pick]
    else:
        pw = lights.power_weights()
        pick = np.minimum(np.searchsorted(np.cumsum(pw), u_pick, side="right"), count - 1)
        prob[:] = pw[pick]
        for k in np.unique(pick):
            sel = np.nonzero(pick == k)[0]
            ldir[sel], dist[sel], e[sel] = lights.sample(int(k), s.take(sel), u[sel])
    e = np.where((prob > 0)[:, None], e / np.maximum(prob, 1e-30)[:, None], 0).astype(np.float32)
    if shadowed:
        e = e * visible(data, tracer, s, ldir, dist, e.max(axis=1) > 0)[:, None]
    return e


def fresnel_schlick(s: Surface, view_dir: np.ndarray) -> np.ndarray:
    """Schlick's Fresnel with F0 = 0.04 for dielectrics and the albedo for metals."""
    f0 = 0.04 * (1 - s.metallic[:, None]) + s.albedo * s.metallic[:, None]
    cos = np.clip(-np.einsum("ij,ij->i", s.n, view_dir), 0, 1)
    return (f0 + (1 - f0) * ((1 - cos) ** 5)[:, None]).astype(np.float32)


def trace_from(data: SceneData, tracer: Tracer, s: Surface, dirs: np.ndarray):
    """Trace rays leaving surface points; returns (hit index, surfaces at the hits, miss index)."""
    o = data.offset(s, dirs)
    hits = tracer.intersect(o, dirs)
    hit = np.nonzero(hits.hit)[0]
    miss = np.nonzero(~hits.hit)[0]
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
