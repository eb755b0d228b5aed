"""A scene's triangles and materials as the flat arrays that every ray-tracing backend shades
hits with (the Embree backend's kernels read them as numpy arrays, the Slang backend uploads
them): positions, per-triangle shading rows, face normals, materials and one flat texel array
of every base-colour texture."""
from __future__ import annotations

import numpy as np


class MeshArrays:
    """The flat arrays of a scene (scenes.model.Scene); eps: the ray offset scale, far: the
    length of rays to a sun or the sky."""

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
        # per triangle: its 3 vertex normals, 3 uvs and material, one 64-byte row (kernels.shade_hits)
        self.corners = np.empty((len(self.indices), 16), np.float32)
        self.corners[:, 0:9] = self.normals[self.indices].reshape(-1, 9)
        self.corners[:, 9:15] = self.uvs[self.indices].reshape(-1, 6)
        self.corners[:, 15] = self.material_ids
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
        diagonal = scene.diagonal  # a pass over every vertex: once
        self.eps = np.float32(max(diagonal * 2e-5, 1e-5))
        self.far = np.float32(max(diagonal * 4.0, 1.0))

