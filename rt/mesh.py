"""A scene's triangles and materials as the flat arrays that every ray-tracing backend shades
hits with (the Embree backend's kernels read them as numpy arrays, the Slang backend uploads
them): positions, per-triangle shading rows, face normals, materials and one flat texel array
of every texture layer (base colour, occlusion-roughness-metallic, normal, emission)."""
from __future__ import annotations

import numpy as np

LAYERS = 4  # texture layers per material: base colour (RGBA), ORM, normal, emission
LAYER_BASE, LAYER_ORM, LAYER_NORMAL, LAYER_EMISSION = range(LAYERS)
CORNER_COLUMNS, TANGENT_COLUMNS = 16, 28  # a triangle's row without / with vertex tangents


class MeshArrays:
    """The flat arrays of a scene (scenes.model.Scene); far: the length of rays to a sun or the sky."""

    def __init__(self, scene):
        self.scene = scene
        f32 = lambda a: np.ascontiguousarray(a, np.float32)  # noqa: E731
        self.positions = f32(scene.positions)
        self.normals = f32(scene.normals)
        self.uvs = f32(scene.uvs)
        self.indices = np.ascontiguousarray(scene.indices, np.int32)
        self.material_ids = np.ascontiguousarray(scene.material_ids, np.int32)
        corners = self.positions[self.indices]  # (T, 3 vertices, 3)
        e1, e2 = corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]
        cross = np.empty_like(e1)  # e1 x e2, written out: np.cross makes several temporaries
        cross[:, 0] = e1[:, 1] * e2[:, 2] - e1[:, 2] * e2[:, 1]
        cross[:, 1] = e1[:, 2] * e2[:, 0] - e1[:, 0] * e2[:, 2]
        cross[:, 2] = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
        length = np.sqrt(np.einsum("ij,ij->i", cross, cross))
        self.tri_area = f32(0.5 * length)
        self.face_normals = f32(cross / np.maximum(length, 1e-30)[:, None])
        # per triangle: its 3 vertex normals, 3 uvs and material, one 64-byte row (kernels.shade_hits),
        # then where the scene has normal maps its 3 vertex tangents (xyz, handedness)
        tangents = getattr(scene, "tangents", None)
        self.corners = np.empty((len(self.indices), CORNER_COLUMNS if tangents is None else TANGENT_COLUMNS),
                                np.float32)
        self.corners[:, 0:9] = self.normals[self.indices].reshape(-1, 9)
        self.corners[:, 9:15] = self.uvs[self.indices].reshape(-1, 6)
        self.corners[:, 15] = self.material_ids
        if tangents is not None:
            self.corners[:, 16:28] = np.asarray(tangents, np.float32)[self.indices].reshape(-1, 12)
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
        # per triangle its 3 vertex colours (glTF COLOR_0, times the base colour), or one white row
        colors = getattr(scene, "colors", None)
        self.tri_colors = (np.ones((1, 9), np.float32) if colors is None else
                           np.ascontiguousarray(np.asarray(colors, np.float32)[self.indices].reshape(-1, 9)))
        diagonal = scene.diagonal  # a pass over every vertex: once
        self.far = np.float32(max(diagonal * 4.0, 1.0))

