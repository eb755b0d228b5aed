"""Hit shading and light sampling shared by every ray-traced pass.

Conventions (DESIGN.md): Lambertian albedo/pi; point/spot intensity I in W/sr with
irradiance I cos / d^2; sun irradiance E in W/m^2 with an optional angular radius; emissive
triangles emit radiance Le and are area lights: each emissive cluster (scenes/model.py) is one
light, and within it a triangle is picked with probability ~ area x power. The spot cone
falloff is glTF's (squared linear ramp in cos), as in shaders/forward.frag.

The per-point maths runs in compiled kernels (rt/embree/kernels.py); this module owns the data and
the order of work: build rays, trace them in one batch, combine.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rt.embree import kernels, layout, raygen, rtcore, scratch
from rt.embree.tracer import Hits, Tracer
from rt.mesh import MeshArrays

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

    def soa(self, name: str | None = None) -> tuple[np.ndarray, int]:
        """What the ray generators read (rt/embree/raygen.py): (rows, first column), the rows (9, n)
        px, py, pz, nx, ny, nz, ngx, ngy, ngz, from column 0; in this thread's scratch buffer
        `name` when given."""
        out = np.empty((9, len(self)), np.float32) if name is None else scratch.buffer(name, (9, len(self)))
        raygen.surface_soa(self.p, self.n, self.ng, out)
        return out, 0


def empty_surface(n: int, name: str | None = None) -> Surface:
    """Room for n points: fresh arrays, or this thread's scratch buffers `name` (rt/embree/scratch.py)."""
    if name is None:
        v, c = (lambda: np.empty((n, 3), np.float32)), (lambda: np.empty(n, np.float32))  # noqa: E731
    else:
        fields = iter(("p", "n", "ng", "albedo", "roughness", "metallic", "emissive"))
        v = lambda: scratch.buffer(f"{name}.{next(fields)}", (n, 3))  # noqa: E731
        c = lambda: scratch.buffer(f"{name}.{next(fields)}", (n,))  # noqa: E731
    return Surface(v(), v(), v(), v(), c(), c(), v())


class SceneData(MeshArrays):
    """The scene in the flat arrays that the kernels shade with: the mesh (rt/mesh.py) and
    its lights (LightSet)."""

    def __init__(self, scene):
        super().__init__(scene)
        self.lights = LightSet(scene, self)
        self._kernel_scene = None

    # -- surfaces ----------------------------------------------------------------------------
    def surface(self, hits: Hits, dirs: np.ndarray, origins: np.ndarray, sel=None, out: Surface | None = None):
        """Shading data at the hits of rays: all of them (they must all hit), or those listed
        in sel; written into `out` when given (a Surface of at least that many points)."""
        n = hits.prim.shape[0] if sel is None else sel.shape[0]
        if sel is None:
            sel = np.arange(n)
        out = empty_surface(n) if out is None else out.take(slice(0, n))
        if n:
            kernels.shade_hits(sel, hits.prim, hits.u, hits.v, hits.t, np.ascontiguousarray(origins, np.float32),
                               np.ascontiguousarray(dirs, np.float32), self.corners, self.face_normals,
                               self.base_color, self.roughness, self.metallic, self.emissive, self.tex_offset,
                               self.tex_w, self.tex_h, self.tex_data, out.p, out.n, out.ng, out.albedo,
                               out.roughness, out.metallic, out.emissive)
        return out

    @property
    def mesh_args(self) -> tuple:
        """What surface() shades hits with, for compiled kernels that shade hits themselves."""
        return (self.corners, self.face_normals, self.base_color, self.roughness, self.metallic, self.emissive,
                self.tex_offset, self.tex_w, self.tex_h, self.tex_data)

    @property
    def kernel_scene(self):
        """This scene as the whole-frame kernels read it (kernel_args.SceneArgs), built once."""
        if self._kernel_scene is None:
            from rt.embree.kernel_args import SceneArgs

            self._kernel_scene = SceneArgs(self.mesh_args, self.lights.kernel_args, self.eps, self.far)
        return self._kernel_scene

    def offset(self, s: Surface, toward: np.ndarray | None = None) -> np.ndarray:
        """Ray origins nudged off the surface (tnear stays 0, as embreex had it), on the side of `toward`."""
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
        self.lum = f32(rad @ LUMA, (-1,))
        self.spot_scale = f32(1.0 / np.maximum(cos_in - cos_out, 1e-3), (-1,))
        # one row per emitting triangle, clusters one after another: what sampling a point on it needs
        c_tri = np.concatenate(tris) if tris else np.zeros(0, np.int64)
        c_pmf = np.concatenate(pmf) if pmf else np.zeros(0)
        i = data.indices[c_tri]
        p0 = data.positions[i[:, 0]]
        rows = np.zeros((c_tri.size, layout.LIGHT_ROW), np.float32)
        rows[:, layout.VERTEX:layout.VERTEX + 3] = p0
        rows[:, layout.EDGE1:layout.EDGE1 + 3] = data.positions[i[:, 1]] - p0
        rows[:, layout.EDGE2:layout.EDGE2 + 3] = data.positions[i[:, 2]] - p0
        rows[:, layout.FACE_NORMAL:layout.FACE_NORMAL + 3] = data.face_normals[c_tri]
        if c_tri.size:
            rows[:, layout.EMISSION:layout.EMISSION + 3] = np.concatenate(le) * (data.tri_area[c_tri] / c_pmf)[:, None]
            rows[:, layout.TWO_SIDED] = np.concatenate(double)
        self.analytic = (kind, pos, d.astype(np.float32), rad, cos_out, self.spot_scale, f32(np.cos(ang), (-1,)),
                         self.lum)  # suns: the cosine of their angular radius
        self.emitters = (np.asarray(start, np.int64), rows,
                         f32(np.concatenate(keep) if keep else [], (-1,)),
                         np.concatenate(alias).astype(np.int32) if alias else np.zeros(0, np.int32))
        # what picking a light needs, as structure-of-arrays (rt/embree/raygen.py: _light_weights); point
        # lights get a cone that is never cut (t = 1)
        spot = kind == 1
        col = lambda a: np.ascontiguousarray(a, np.float32)  # noqa: E731
        self.guide = (*(col(pos[:, a]) for a in range(3)), *(col(d[:, a]) for a in range(3)), col(self.lum),
                      col(np.where(spot, cos_out, -2.0)), col(np.where(spot, self.spot_scale, 1.0)),
                      np.ascontiguousarray(kind == 2), *(col(self.cluster_centre[:, a]) for a in range(3)),
                      col(self.cluster_radius), col(self.cluster_power))
        self.data = data

    def rays(self, k: int, G, keys, dim: int, origin, direction, tmax, e, idx, scene=0, acc=raygen.NOT_TRACED) -> int:
        """Shadow rays to light k from points G = (rows, first column) (Surface.soa), packed
        (rt/embree/raygen.py), or if scene traced and what gets through added to acc; returns their count."""
        eps, far = self.data.eps, self.data.far
        out = (origin, direction, tmax, e, idx, rtcore.target(scene), acc)
        if k < self.count_analytic:
            return raygen.analytic_shadow_rays(k, *G, keys, dim, self.analytic, eps, far, *out)
        start, rows, keep, alias = self.emitters
        j = k - self.count_analytic
        return raygen.cluster_shadow_rays(start[j], start[j + 1], *G, keys, dim, rows, keep, alias, eps, *out)

    def one_rays(self, G, keys, dim: int, origin, direction, tmax, e, idx, scene=0, acc=raygen.NOT_TRACED) -> int:
        """One shadow ray per point of G = (rows, first column) (Surface.soa) to a light picked
        by its estimated contribution, packed, or if scene traced and added to acc."""
        weights = scratch.buffer("light.w", (self.count + raygen.SCRATCH_ROWS, raygen.BLOCK))
        return raygen.one_light_shadow_rays(*G, keys, dim, self.analytic, self.emitters, self.guide, self.data.eps,
                                            self.data.far, weights, origin, direction, tmax, e, idx,
                                            rtcore.target(scene), acc)

    @property
    def kernel_args(self) -> tuple:
        """What raygen.direct_block needs of the lights."""
        return self.analytic, self.emitters, self.guide, self.count

    @property
    def count(self) -> int:
        """Analytic lights, plus one per emissive cluster."""
        return self.count_analytic + self.cluster_count

    @property
    def has_emissive(self) -> bool:
        return self.cluster_count > 0


def _gather(tracer: Tracer, total, rays, m: int, shadowed: bool, scene: int) -> None:
    """total += the light of the first m packed rays that reach their light (added already by
    their generator if it traced them: scene)."""
    if scene:
        tracer.rays_traced += m
        return
    o, d, t, idx, e = rays
    blocked = tracer.occluded(o[:m], d[:m], t[:m]) if (shadowed and m) else np.zeros(m, np.bool_)
    raygen.add_unblocked(total, idx, e, blocked, m)


def direct_one(data: SceneData, tracer: Tracer, s: Surface, rng, shadowed: bool = True, out=None,
               G=None) -> np.ndarray:
    """Irradiance x cos from ONE light per point, picked with probability ~ its estimated
    contribution there and divided by that probability: accumulates to every light's sum.
    out: an (N,3) array to write into (zeroed here) instead of a new one; G: s.soa() if at hand."""
    n = len(s)
    dim = rng.reserve(4)
    total = np.zeros((n, 3), np.float32) if out is None else out
    total.fill(0)
    if data.lights.count == 0 or n == 0:
        return total
    rays = scratch.rays("light", n, with_light=True)
    o, d, t, idx, e = rays
    G = s.soa("light.soa") if G is None else G
    scene = tracer.inline_scene() if shadowed else 0  # then the generator traces, adding into total
    _gather(tracer, total, rays, data.lights.one_rays(G, rng.key, dim, o, d, t, e, idx, scene, total), shadowed, scene)
    return total


def cosine_directions(s: Surface, rng) -> np.ndarray:
    """(N,3) cosine-weighted directions about the shading normals (may point below the true surface)."""
    out = np.empty((len(s), 3), np.float32)
    raygen.cosine_dirs(s.n, rng.key, rng.reserve(2), out)
    return out


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
    return hit, data.surface(hits, dirs, o, sel=hit), miss


def mirror(d: np.ndarray, s: Surface) -> np.ndarray:
    """Mirror direction about the shading normal; about the face normal where that would
    send the ray into the surface."""
    r = d - 2 * np.einsum("ij,ij->i", d, s.n)[:, None] * s.n
    bad = np.einsum("ij,ij->i", r, s.ng) <= 0
    if bad.any():
        rg = d - 2 * np.einsum("ij,ij->i", d, s.ng)[:, None] * s.ng
        r = np.where(bad[:, None], rg, r)
    return r.astype(np.float32)
