"""A scene's textures made smaller for a renderer (option textures.max_size), when GPU or host
memory is short: every layer whose longer side exceeds the limit is box-filtered down to it
(normal maps renormalised), in a copy of the scene that shares everything else; the source
scene is not changed, and each limit's copy is made once."""
from __future__ import annotations

import dataclasses

import numpy as np


def limited(scene, max_side: int):
    """scene, or (max_side > 0 and some texture larger) its copy with smaller textures."""
    if max_side <= 0:
        return scene
    if not any(max(t.shape[:2]) > max_side for m in scene.materials for t in m.layers() if t is not None):
        return scene
    made = scene.__dict__.setdefault("_texture_limits", {})
    if max_side not in made:
        materials = [_material(m, max_side) for m in scene.materials]
        copy = dataclasses.replace(scene, materials=materials)
        copy.__dict__.pop("_texture_limits", None)
        made[max_side] = copy
    return made[max_side]


def _material(m, max_side: int):
    texture, orm, normal, emissive = (shrink(t, max_side) for t in m.layers())
    if normal is not None and normal is not m.normal_map:
        normal = (normal / np.maximum(np.linalg.norm(normal, axis=-1, keepdims=True), 1e-6)).astype(np.float32)
    return dataclasses.replace(m, texture=texture, orm=orm, normal_map=normal, emissive_map=emissive)


def shrink(image: np.ndarray | None, max_side: int) -> np.ndarray | None:
    """image (H x W x C float32) box-filtered so that its longer side is max_side at most (the
    same image where it already is): the mean of whole blocks where the factor divides both
    sides, else each channel resampled by Pillow's box filter."""
    if image is None or max(image.shape[:2]) <= max_side:
        return image
    h, w, c = image.shape
    scale = max_side / max(h, w)
    nh, nw = max(1, round(h * scale)), max(1, round(w * scale))
    if h % nh == 0 and w % nw == 0:
        return image.reshape(nh, h // nh, nw, w // nw, c).mean((1, 3), dtype=np.float32)
    from PIL import Image

    channels = [np.asarray(Image.fromarray(np.ascontiguousarray(image[..., k], np.float32), mode="F")
                           .resize((nw, nh), Image.BOX), np.float32) for k in range(c)]
    return np.stack(channels, -1)
