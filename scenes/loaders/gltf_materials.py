"""glTF 2.0 metallic-roughness materials -> scenes.model.Material: the base colour texture is
multiplied with its factor where sampled, the other factors are baked into their layers
(occlusion-roughness-metallic, normal, emission).

All of a material's textures are sampled with one set of uvs: the texCoord set and
KHR_texture_transform of its first texture (base colour, then metallic-roughness, normal,
occlusion, emission) are baked into its primitives' uvs; a texture that asks for another set
or transform is read with those (a warning says so). The wrap mode is the base texture's
sampler's; filtering is always linear."""
from __future__ import annotations

import math
import warnings

import numpy as np

from scenes.loaders.gltf_checks import WRAP_MODES
from scenes.model import Material

TEXTURE_ORDER = (("pbr", "baseColorTexture"), ("pbr", "metallicRoughnessTexture"), ("m", "normalTexture"),
                 ("m", "occlusionTexture"), ("m", "emissiveTexture"))


class UvRule:
    """Which TEXCOORD set a material's textures read and the 3x3 transform applied to it."""

    def __init__(self, texcoord: int = 0, matrix: np.ndarray | None = None):
        self.texcoord, self.matrix = texcoord, matrix

    def key(self) -> tuple:
        return self.texcoord, None if self.matrix is None else tuple(np.round(self.matrix, 9).ravel())

    def apply(self, uv: np.ndarray) -> np.ndarray:
        if self.matrix is None:
            return uv
        m = self.matrix
        out = uv @ m[:2, :2].T + m[:2, 2]
        return np.where(np.isfinite(out), out, 0.0).astype(np.float32)


def _uv_rule(ref: dict) -> UvRule:
    ext = ref.get("extensions", {}).get("KHR_texture_transform")
    texcoord = ref.get("texCoord", 0)
    if ext is None:
        return UvRule(texcoord)
    texcoord = ext.get("texCoord", texcoord)
    ox, oy = ext.get("offset", (0.0, 0.0))
    r = float(ext.get("rotation", 0.0))
    sx, sy = ext.get("scale", (1.0, 1.0))
    translation = np.array([[1, 0, ox], [0, 1, oy], [0, 0, 1]], np.float64)
    rotation = np.array([[math.cos(r), math.sin(r), 0], [-math.sin(r), math.cos(r), 0], [0, 0, 1]], np.float64)
    scale = np.diag([sx, sy, 1.0])
    return UvRule(texcoord, translation @ rotation @ scale)


def read_material(reader, k: int, m: dict) -> tuple[Material, UvRule]:
    """The material and the uv rule of its textures; reader: the glTF reader (texture())."""
    pbr = m.get("pbrMetallicRoughness", {})
    name = str(m.get("name", f"material_{k}"))
    refs = {key: (pbr if where == "pbr" else m).get(key) for where, key in TEXTURE_ORDER}
    present = [key for key, ref in refs.items() if ref is not None]
    rule = _uv_rule(refs[present[0]]) if present else UvRule()
    for key in present[1:]:
        if _uv_rule(refs[key]).key() != rule.key():
            warnings.warn(f"{reader.path.name}: material {name[:60]!r}: {key} uses other texture coordinates "
                          f"or a transform than {present[0]}; rtlab samples all of a material's textures with "
                          f"the first's", stacklevel=3)
    factor = np.asarray(pbr.get("baseColorFactor", (1, 1, 1, 1)), np.float64)
    factor[:3] = np.minimum(factor[:3], 1.0)
    factor[3] = min(factor[3], 1.0)
    strength = float(m.get("extensions", {}).get("KHR_materials_emissive_strength", {}).get("emissiveStrength", 1))
    emissive = np.asarray(m.get("emissiveFactor", (0, 0, 0)), np.float64) * strength
    roughness = float(pbr.get("roughnessFactor", 1.0))
    metallic = float(pbr.get("metallicFactor", 1.0))
    mode = m.get("alphaMode", "OPAQUE")
    mat = Material(name=name, base_color=tuple(float(c) for c in factor), roughness=roughness, metallic=metallic,
                   emissive=tuple(float(e) for e in emissive), double_sided=bool(m.get("doubleSided", False)),
                   alpha_mode=mode, alpha_cutoff=float(m.get("alphaCutoff", 0.5)) if mode == "MASK" else 0.5)

    def tex(key, srgb, alpha=False):
        return reader.texture(refs[key]["index"], srgb, alpha) if refs.get(key) is not None else None

    base = tex("baseColorTexture", True, alpha=mode != "OPAQUE")
    if base is not None:
        mat.texture = base  # multiplied with base_color where sampled (Material.texture)
        mat.wrap = reader.wrap(refs["baseColorTexture"]["index"])
        mat.nearest = reader.nearest(refs["baseColorTexture"]["index"])
    elif present:
        mat.wrap = reader.wrap(refs[present[0]]["index"])
        mat.nearest = reader.nearest(refs[present[0]]["index"])
    mr, occ = tex("metallicRoughnessTexture", False), tex("occlusionTexture", False)
    if mr is not None or occ is not None:
        shape = max((t.shape[:2] for t in (mr, occ) if t is not None), key=lambda s: s[0] * s[1])
        orm = np.empty(shape + (3,), np.float32)
        orm[..., 0] = 1.0 if occ is None else 1.0 + float(m["occlusionTexture"].get("strength", 1.0)) * (
            _resample(occ, shape)[..., 0] - 1.0)
        orm[..., 1] = roughness if mr is None else roughness * _resample(mr, shape)[..., 1]
        orm[..., 2] = metallic if mr is None else metallic * _resample(mr, shape)[..., 2]
        mat.orm = orm
    normal = tex("normalTexture", False)
    if normal is not None:
        scale = float(m["normalTexture"].get("scale", 1.0))
        n = normal * 2.0 - 1.0
        n[..., :2] *= scale
        length = np.linalg.norm(n, axis=-1, keepdims=True)
        mat.normal_map = np.where(length > 1e-6, n / np.maximum(length, 1e-6), (0.0, 0.0, 1.0)).astype(np.float32)
    glow = tex("emissiveTexture", True)
    if glow is not None:
        mat.emissive_map = (glow * emissive).astype(np.float32)
    return mat, rule


NEAREST = (9728, 9984, 9986)  # glTF's NEAREST, NEAREST_MIPMAP_NEAREST, NEAREST_MIPMAP_LINEAR


def wrap_modes(sampler: dict) -> tuple:
    return WRAP_MODES[sampler.get("wrapS", 10497)], WRAP_MODES[sampler.get("wrapT", 10497)]


def _resample(tex: np.ndarray, shape: tuple) -> np.ndarray:
    """Nearest-texel resampling of a texture to (h, w), for layers combined from two images."""
    if tex.shape[:2] == shape:
        return tex
    h, w = tex.shape[:2]
    yi = (np.arange(shape[0]) * h // shape[0])[:, None]
    xi = (np.arange(shape[1]) * w // shape[1])[None, :]
    return tex[yi, xi]


def generate_tangents(pos: np.ndarray, nrm: np.ndarray, uv: np.ndarray, tri: np.ndarray) -> np.ndarray:
    """(V,4) per-vertex tangents from uv gradients (area-weighted sum of the faces' tangents,
    orthogonalised against the normal; w: the handedness of the uv mapping), for files with a
    normal map and no TANGENT attribute."""
    p = pos.astype(np.float64)[tri]
    t = uv.astype(np.float64)[tri]
    e1, e2 = p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]
    d1, d2 = t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]
    det = d1[:, 0] * d2[:, 1] - d2[:, 0] * d1[:, 1]
    r = np.where(np.abs(det) > 1e-20, 1.0 / np.where(det == 0, 1.0, det), 0.0)[:, None]
    face_t = (e1 * d2[:, 1:2] - e2 * d1[:, 1:2]) * r
    face_b = (e2 * d1[:, 0:1] - e1 * d2[:, 0:1]) * r
    tan = np.zeros_like(pos, dtype=np.float64)
    bit = np.zeros_like(pos, dtype=np.float64)
    for k in range(3):
        np.add.at(tan, tri[:, k], face_t)
        np.add.at(bit, tri[:, k], face_b)
    n = nrm.astype(np.float64)
    n = n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-20)
    tan -= n * np.einsum("ij,ij->i", n, tan)[:, None]
    length = np.linalg.norm(tan, axis=1, keepdims=True)
    fallback = np.cross(n, np.where(np.abs(n[:, :1]) < 0.9, [[1.0, 0, 0]], [[0, 0, 1.0]]))
    tan = np.where(length > 1e-12, tan / np.maximum(length, 1e-20), fallback / np.maximum(
        np.linalg.norm(fallback, axis=1, keepdims=True), 1e-20))
    w = np.where(np.einsum("ij,ij->i", np.cross(n, tan), bit) < 0, -1.0, 1.0)
    return np.concatenate([tan, w[:, None]], 1).astype(np.float32)
