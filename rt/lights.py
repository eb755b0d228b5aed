"""A scene's lights as the flat arrays every ray-tracing backend samples: its analytic lights
(point, spot, sun) plus one light per emissive cluster, whose triangles are picked with
probability ~ area x power (alias tables), and what picking one light per point weighs
(`guide`). The Embree kernels read them as numpy arrays; the Slang backend uploads them."""
from __future__ import annotations

import numpy as np

from rt import layout

LUMA = np.array([0.2126, 0.7152, 0.0722], np.float32)
KINDS = {"point": 0, "spot": 1, "directional": 2}


def alias_table(weights: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Walker's alias table: (keep probability, alias index) per slot, for O(1) sampling."""
    n = weights.size
    p = weights / weights.sum() * n
    keep = np.ones(n)
    alias = np.arange(n)
    small = [i for i in range(n) if p[i] < 1.0]
    large = [i for i in range(n) if p[i] >= 1.0]
    while small and large:
        s, g = small.pop(), large.pop()
        keep[s], alias[s] = p[s], g
        p[g] -= 1.0 - p[s]
        (small if p[g] < 1.0 else large).append(g)
    return keep, alias


class LightSet:
    """Analytic lights plus one light per emissive cluster, as flat arrays for the kernels."""

    def __init__(self, scene, data):
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
            e = scene.triangle_emission()[group]  # textured emission: its mean over each triangle
            weight = data.tri_area[group].astype(np.float64) * np.maximum(e @ LUMA, 0)
            total = weight.sum()
            if total <= 0:
                continue
            tris.append(group.astype(np.int64))
            k, a = alias_table(weight)
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
            rows[:, layout.AREA_PDF] = c_pmf / np.maximum(data.tri_area[c_tri], 1e-30)
        self.analytic = (kind, pos, d.astype(np.float32), rad, cos_out, self.spot_scale, f32(np.cos(ang), (-1,)),
                         self.lum)  # suns: the cosine of their angular radius
        # per triangle of the scene: the light (index among all lights) whose cluster holds it, or -1
        self.tri_light = np.full(len(data.indices), -1, np.int64)
        for j, t in enumerate(tris):
            self.tri_light[t] = self.count_analytic + j
        self.tri_row = np.full(len(data.indices), -1, np.int64)  # and its row of `emitters`
        self.tri_row[c_tri] = np.arange(c_tri.size)
        self.emitters = (np.asarray(start, np.int64), rows,
                         f32(np.concatenate(keep) if keep else [], (-1,)),
                         np.concatenate(alias).astype(np.int32) if alias else np.zeros(0, np.int32))
        # what picking a light needs, as structure-of-arrays (rt/embree/light_sampling.py: _light_weights); point
        # lights get a cone that is never cut (t = 1)
        spot = kind == 1
        col = lambda a: np.ascontiguousarray(a, np.float32)  # noqa: E731
        self.guide = (*(col(pos[:, a]) for a in range(3)), *(col(d[:, a]) for a in range(3)), col(self.lum),
                      col(np.where(spot, cos_out, -2.0)), col(np.where(spot, self.spot_scale, 1.0)),
                      np.ascontiguousarray(kind == 2), *(col(self.cluster_centre[:, a]) for a in range(3)),
                      col(self.cluster_radius), col(self.cluster_power))
        self.data = data  # the scene's MeshArrays (rt/mesh.py)

    def analytic_rows(self) -> np.ndarray:
        """One light row (rt/layout.py) per analytic light, as the Embree backend's
        light_sampling.analytic_rows makes them in its kernels."""
        kind, pos, d, rad, cos_out, spot_scale, cos_ang, _ = self.analytic
        rows = np.zeros((len(kind), layout.LIGHT_ROW), np.float32)
        spot = kind == 1
        rows[:, layout.POSITION:layout.POSITION + 3] = pos
        rows[:, layout.TO_SUN:layout.TO_SUN + 3] = -d
        rows[:, layout.RADIANCE:layout.RADIANCE + 3] = rad
        rows[:, layout.CONE_COS] = np.where(spot, cos_out, -2.0)
        rows[:, layout.CONE_SCALE] = np.where(spot, spot_scale, 1.0)
        rows[:, layout.SUN_COS] = cos_ang
        rows[:, layout.IS_SUN] = kind == 2
        return rows

    @property
    def kernel_args(self) -> tuple:
        """What the Embree backend's light_sampling.direct_all and direct_one need of the lights."""
        return self.analytic, self.emitters, self.guide, self.count

    @property
    def count(self) -> int:
        """Analytic lights, plus one per emissive cluster."""
        return self.count_analytic + self.cluster_count

    @property
    def has_emissive(self) -> bool:
        return self.cluster_count > 0
