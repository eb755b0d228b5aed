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

from rt.embree import brdf, kernels, light_sampling, raygen, rtcore, scratch
from rt.embree.tracer import Hits, Tracer
from rt.lights import LUMA, LightSet  # noqa: F401  (LUMA: re-exported for reference.py)
from rt.mesh import MeshArrays

INV_PI = np.float32(1 / np.pi)


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

    def arrays(self) -> tuple:
        """The fields in order, as the kernels that write a surface take them (kernels.shade_hits)."""
        return self.p, self.n, self.ng, self.albedo, self.roughness, self.metallic, self.emissive

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
            kernels.shade_hits(sel, (hits.prim, hits.u, hits.v, hits.t),
                               (np.ascontiguousarray(origins, np.float32), np.ascontiguousarray(dirs, np.float32)),
                               self.mesh_args, out.arrays())
        return out

    @property
    def mesh_args(self) -> tuple:
        """What surface() shades hits with, for compiled kernels that shade hits themselves."""
        return (self.corners, self.face_normals, self.base_color, self.roughness, self.metallic, self.emissive,
                self.tex_offset, self.tex_w, self.tex_h, self.wrap, self.tex_data, self.tri_colors)

    @property
    def kernel_scene(self):
        """This scene as the whole-frame kernels read it (kernel_args.SceneArgs), built once."""
        if self._kernel_scene is None:
            from rt.embree.kernel_args import SceneArgs

            self._kernel_scene = SceneArgs(self.mesh_args, self.lights.kernel_args, self.far)
        return self._kernel_scene

    @staticmethod
    def offset(s: Surface, toward: np.ndarray | None = None) -> np.ndarray:
        """Ray origins nudged off the surface (raygen.offset_origin: tnear stays 0, as embreex had
        it), on the side of `toward`."""
        ng = s.ng
        if toward is not None:
            side = np.einsum("ij,ij->i", ng, toward) < 0
            ng = np.where(side[:, None], -ng, ng)
        return raygen.offset_origins(s.p, np.ascontiguousarray(ng, np.float32), np.empty((len(s.p), 3), np.float32))


def light_rays(lights: LightSet, k: int, G, keys, dim: int, origin, direction, tmax, e, idx, scene=0,
               acc=raygen.NOT_TRACED) -> int:
    """Shadow rays to light k from points G = (rows, first column) (Surface.soa), packed
    (rt/embree/raygen.py), or if scene traced and what gets through added to acc; returns their
    count."""
    far = lights.data.far
    out = ((origin, direction, tmax, e, idx), rtcore.target(scene), acc)
    if k < lights.count_analytic:
        return light_sampling.analytic_shadow_rays(k, *G, keys, dim, lights.analytic, far, *out)
    start, rows, keep, alias = lights.emitters
    j = k - lights.count_analytic
    return light_sampling.cluster_shadow_rays(start[j], start[j + 1], *G, keys, dim, (rows, keep, alias), *out)


def one_light_rays(lights: LightSet, G, keys, dim: int, origin, direction, tmax, e, idx, scene=0,
                   acc=raygen.NOT_TRACED, mis: bool = False) -> int:
    """One shadow ray per point of G = (rows, first column) (Surface.soa) to a light picked
    by its estimated contribution, packed, or if scene traced and added to acc. mis: emitters'
    samples weighted against cosine-weighted sampling (raygen.mis_weight)."""
    weights = scratch.buffer("light.w", (lights.count + light_sampling.SCRATCH_ROWS, light_sampling.BLOCK))
    return light_sampling.one_light_shadow_rays(*G, keys, dim, lights.kernel_args, lights.data.far, weights,
                                                (origin, direction, tmax, e, idx), rtcore.target(scene), acc, mis)


def _gather(tracer: Tracer, total, rays, m: int, shadowed: bool, scene: int, G) -> None:
    """total += the light of the first m packed rays that reach their light (added already by
    their generator if it traced them: scene); G: the points' (rows, first column)."""
    if scene:
        tracer.rays_traced += m
        return
    o, d, t, idx, e = rays
    blocked = tracer.occluded(o[:m], d[:m], t[:m]) if (shadowed and m) else np.zeros(m, np.bool_)
    raygen.add_unblocked(total, idx, d, e, blocked, m, *G)


def direct_one(data: SceneData, tracer: Tracer, s: Surface, rng, shadowed: bool = True, out=None,
               G=None, mis: bool = False) -> np.ndarray:
    """Irradiance x cos from ONE light per point, picked with probability ~ its estimated
    contribution there and divided by that probability: accumulates to every light's sum.
    out: an (N,3) array to write into (zeroed here) instead of a new one, or a GGX accumulator
    (rt/embree/brdf.py: its sums zeroed here); G: s.soa() if at hand; mis: emitters' samples
    weighted against cosine-weighted sampling (the reference's diffuse vertices), or with an
    accumulator that has brdf.P_SPEC against the BRDF's lobes (its GGX vertices)."""
    n = len(s)
    dim = rng.reserve(4)
    total = np.zeros((n, 3), np.float32) if out is None else out
    total[:, :min(total.shape[1], brdf.SUM_EDVW + 3)] = 0
    if data.lights.count == 0 or n == 0:
        return total
    rays = scratch.rays("light", n, with_light=True)
    o, d, t, idx, e = rays
    G = s.soa("light.soa") if G is None else G
    scene = tracer.inline_scene() if shadowed else 0  # then the generator traces, adding into total
    m = one_light_rays(data.lights, G, rng.key, dim, o, d, t, e, idx, scene, total, mis)
    _gather(tracer, total, rays, m, shadowed, scene, G)
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


def trace_from(data: SceneData, tracer: Tracer, s: Surface, dirs: np.ndarray, origins: np.ndarray | None = None,
               with_hits: bool = False):
    """Trace rays leaving surface points; returns (hit index, surfaces at the hits, miss index)
    and with_hits the Embree hits too (their triangles and distances)."""
    o = data.offset(s, dirs) if origins is None else origins
    hits = tracer.intersect(o, dirs)
    hit = np.flatnonzero(hits.prim >= 0)
    miss = np.flatnonzero(hits.prim < 0)
    out = hit, data.surface(hits, dirs, o, sel=hit), miss
    return out + (hits,) if with_hits else out


def emission_weight(data: SceneData, s: Surface, dirs: np.ndarray, prim: np.ndarray, t: np.ndarray,
                    density: np.ndarray | None = None) -> np.ndarray:
    """For rays drawn cosine-weighted (or with the given densities) from points s along dirs
    that hit triangles prim t away, the power heuristic's weight of the emission they find
    against next-event estimation's drawing of the same direction (light_sampling.emission_weights; 0
    behind a one-sided emitter)."""
    lights = data.lights
    w = np.empty(len(s), np.float32)
    q = np.zeros(0, np.float32) if density is None else np.ascontiguousarray(density, np.float32)
    if len(s):
        light_sampling.emission_weights(s.p, s.n, np.ascontiguousarray(dirs, np.float32), np.ascontiguousarray(prim),
                                        np.ascontiguousarray(t, np.float32), lights.tri_light, lights.tri_row,
                                        lights.emitters[1], lights.guide, lights.count, q, w)
    return w


def mirror(d: np.ndarray, s: Surface) -> np.ndarray:
    """Mirror direction about the shading normal; about the face normal where that would
    send the ray into the surface."""
    r = d - 2 * np.einsum("ij,ij->i", d, s.n)[:, None] * s.n
    bad = np.einsum("ij,ij->i", r, s.ng) <= 0
    if bad.any():
        rg = d - 2 * np.einsum("ij,ij->i", d, s.ng)[:, None] * s.ng
        r = np.where(bad[:, None], rg, r)
    return r.astype(np.float32)
