"""A scene's triangles and materials as the flat arrays that every ray-tracing backend shades
hits with (the Embree backend's kernels read them as numpy arrays, the Slang backend uploads
them): positions, per-triangle shading rows, face normals, materials and one flat texel array
of every texture layer (base colour, occlusion-roughness-metallic, normal, emission)."""
from __future__ import annotations

import os

import numpy as np

CHUNK = 1 << 18  # triangles a thread's share of the per-triangle rows
LAYERS = 4  # texture layers per material: base colour (RGBA), ORM, normal, emission
LAYER_BASE, LAYER_ORM, LAYER_NORMAL, LAYER_EMISSION = range(LAYERS)
CORNER_COLUMNS, TANGENT_COLUMNS = 16, 28  # a triangle's row without / with vertex tangents


def prefetch(scene) -> None:
    """Start making scene's arrays on a thread (the renderer does while GL uploads the scene):
    the first MeshArrays of that scene takes them instead of making them again."""
    from concurrent.futures import ThreadPoolExecutor

    if "_mesh_prefetch" in scene.__dict__:
        return
    pool = ThreadPoolExecutor(1, thread_name_prefix="rtlab-mesh")
    made = MeshArrays.__new__(MeshArrays)
    scene.__dict__["_mesh_prefetch"] = pool.submit(lambda: (made._fill(scene), made)[1])
    pool.shutdown(wait=False)


class MeshArrays:
    """The flat arrays of a scene (scenes.model.Scene); far: the length of rays to a sun or the sky."""

    def __init__(self, scene):
        pending = scene.__dict__.pop("_mesh_prefetch", None)
        if pending is not None:
            try:
                self.__dict__.update(pending.result().__dict__)
                return
            except Exception:  # noqa: BLE001 - e.g. memory: made again here, where it says why
                pass
        self._fill(scene)

    def _fill(self, scene) -> None:
        self.scene = scene
        f32 = lambda a: np.ascontiguousarray(a, np.float32)  # noqa: E731
        self.positions = f32(scene.positions)
        self.normals = f32(scene.normals)
        self.uvs = f32(scene.uvs)
        self.indices = np.ascontiguousarray(scene.indices, np.int32)
        self.material_ids = np.ascontiguousarray(scene.material_ids, np.int32)
        # per triangle: its area and face normal; its 3 vertex normals, 3 uvs and material, one 64-byte
        # row (kernels.shade_hits), then where the scene has normal maps its 3 vertex tangents (xyz,
        # handedness); in chunks on threads (numpy's gathers leave the GIL: 10 M triangles in 2.6 s on one)
        tangents = getattr(scene, "tangents", None)
        self._tangents = None if tangents is None else np.asarray(tangents, np.float32)
        t = len(self.indices)
        self.tri_area = np.empty(t, np.float32)
        self.face_normals = np.empty((t, 3), np.float32)
        self.corners = np.empty((t, CORNER_COLUMNS if tangents is None else TANGENT_COLUMNS), np.float32)
        chunks = [(lo, min(lo + CHUNK, t)) for lo in range(0, t, CHUNK)]
        if len(chunks) > 1:
            from concurrent.futures import ThreadPoolExecutor

            with ThreadPoolExecutor(min(len(chunks), os.cpu_count() or 1)) as pool:
                list(pool.map(lambda c: self._triangle_rows(*c), chunks))
        elif chunks:
            self._triangle_rows(*chunks[0])
        del self._tangents
        mats = scene.materials
        self.base_color = f32([m.base_color[:3] for m in mats])
        self.roughness = f32([m.roughness for m in mats])
        self.metallic = f32([m.metallic for m in mats])
        self.emissive = f32([m.emissive for m in mats])
        # alpha: each material's cutoff (-1: never cut), its base alpha factor and wrap modes
        self.alpha_cutoff = f32([m.alpha_cutoff if m.alpha_tested else -1.0 for m in mats])
        self.base_alpha = f32([m.base_color[3] if len(m.base_color) > 3 else 1.0 for m in mats])
        # wrap modes u, v, and 1 where layers are read at the nearest texel (Material.nearest)
        self.wrap = np.asarray([(*m.wrap, int(m.nearest)) for m in mats], np.int64).reshape(-1, 3)
        # every texture layer (Material.layers: base RGBA, ORM, normal, emission) in one flat
        # RGBA texel array: offset (-1: none), width and height per material and layer
        self.tex_offset = np.full((len(mats), LAYERS), -1, np.int64)
        self.tex_w = np.ones((len(mats), LAYERS), np.int64)
        self.tex_h = np.ones((len(mats), LAYERS), np.int64)
        chunks, offset = [np.zeros((1, 4), np.float32)], 1
        for k, m in enumerate(mats):
            for layer, tex in enumerate(m.layers()):
                if tex is None:
                    continue
                h, w, c = tex.shape
                texels = np.ones((h * w, 4), np.float32)
                texels[:, :min(c, 4)] = tex.reshape(-1, c)[:, :4]
                self.tex_offset[k, layer], self.tex_w[k, layer], self.tex_h[k, layer] = offset, w, h
                chunks.append(texels)
                offset += h * w
        self.tex_data = np.ascontiguousarray(np.concatenate(chunks), np.float32)
        self.has_alpha = bool((self.alpha_cutoff >= 0).any())
        # glTF doubleSided false: primary rays (and the raster) see only the front faces
        # (counter-clockwise, face_normals' side); every other ray sees both, as in Mitsuba
        self.single_sided = np.asarray([not m.double_sided for m in mats], bool).reshape(-1)
        self.has_single_sided = bool(self.single_sided.any())
        # per triangle its 3 vertex colours (glTF COLOR_0, times the base colour), or one white row
        colors = getattr(scene, "colors", None)
        self.tri_colors = (np.ones((1, 9), np.float32) if colors is None else
                           np.ascontiguousarray(np.asarray(colors, np.float32)[self.indices].reshape(-1, 9)))
        diagonal = scene.diagonal  # a pass over every vertex: once
        self.far = np.float32(max(diagonal * 4.0, 1.0))

    def _triangle_rows(self, lo: int, hi: int) -> None:
        """Triangles lo..hi of tri_area, face_normals and corners."""
        idx = self.indices[lo:hi]
        corners = self.positions[idx]  # (n, 3 vertices, 3)
        e1, e2 = corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]
        cross = np.empty_like(e1)  # e1 x e2, written out: np.cross makes several temporaries
        cross[:, 0] = e1[:, 1] * e2[:, 2] - e1[:, 2] * e2[:, 1]
        cross[:, 1] = e1[:, 2] * e2[:, 0] - e1[:, 0] * e2[:, 2]
        cross[:, 2] = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
        length = np.sqrt(np.einsum("ij,ij->i", cross, cross))
        self.tri_area[lo:hi] = 0.5 * length
        self.face_normals[lo:hi] = cross / np.maximum(length, 1e-30)[:, None]
        rows = self.corners[lo:hi]
        rows[:, 0:9] = self.normals[idx].reshape(-1, 9)
        rows[:, 9:15] = self.uvs[idx].reshape(-1, 6)
        rows[:, 15] = self.material_ids[lo:hi]
        if self._tangents is not None:
            rows[:, 16:28] = self._tangents[idx].reshape(-1, 12)

