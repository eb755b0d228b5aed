"""OBJ (+MTL) and PLY through trimesh, converted into the scene model."""
from __future__ import annotations

import os
import re
from pathlib import Path

import numpy as np

from core.errors import UserError
from scenes.loaders.common import check_memory, compute_normals, safe_child, srgb_to_linear
from scenes.model import Environment, Material, Scene

REFERENCE = re.compile(rb"^\s*(mtllib|map_Kd|map_Ka|map_Ks|map_Bump|bump|map_d|map_Ke|norm)\s+(.+?)\s*$",
                       re.MULTILINE)


def check_references(path: Path) -> None:
    """OBJ/MTL name other files; refuse those outside the scene's folder before trimesh reads them."""
    folder = path.resolve().parent
    seen, todo = set(), [path.resolve()]
    while todo:
        f = todo.pop()
        if f in seen or not f.is_file():
            continue
        seen.add(f)
        for kind, ref in REFERENCE.findall(f.read_bytes()):
            name = ref.decode("utf-8", "replace").split()[-1]
            target = safe_child(path, os.path.relpath(f.parent / name, folder))
            if kind == b"mtllib":
                todo.append(target)


def _material_from_trimesh(geom, k: int) -> Material:
    vis = getattr(geom, "visual", None)
    mat = getattr(vis, "material", None)
    name = getattr(mat, "name", None) or f"material_{k}"
    color = (0.8, 0.8, 0.8, 1.0)
    tex = None
    roughness, metallic, emissive = 0.8, 0.0, (0.0, 0.0, 0.0)
    if mat is not None:
        if hasattr(mat, "to_pbr"):
            mat = mat.to_pbr()
        bc = getattr(mat, "baseColorFactor", None)
        if bc is not None:
            bc = np.asarray(bc, float).ravel()
            bc = bc / 255.0 if bc.max() > 1.0 else bc
            color = tuple(srgb_to_linear(bc[:3]).tolist()) + (float(bc[3]) if bc.size > 3 else 1.0,)
        img = getattr(mat, "baseColorTexture", None)
        if img is not None:
            try:
                tex = srgb_to_linear(np.asarray(img.convert("RGB"), np.float32) / 255.0)
            except Exception:  # noqa: BLE001 - a broken texture falls back to the base colour
                tex = None
        if getattr(mat, "roughnessFactor", None) is not None:
            roughness = float(np.clip(mat.roughnessFactor, 0, 1))
        if getattr(mat, "metallicFactor", None) is not None:
            metallic = float(np.clip(mat.metallicFactor, 0, 1))
        ef = getattr(mat, "emissiveFactor", None)
        if ef is not None:
            emissive = tuple(float(e) for e in np.asarray(ef, float).ravel()[:3])
    elif vis is not None and getattr(vis, "kind", None) == "vertex":
        c = np.asarray(vis.vertex_colors, float)[:, :3].mean(axis=0) / 255.0
        color = tuple(srgb_to_linear(c).tolist()) + (1.0,)
    return Material(name, color, tex, roughness, metallic, emissive, True)


def load_mesh_file(path: Path) -> Scene:
    import trimesh

    if path.suffix.lower() == ".obj":
        check_references(path)
    # text OBJ/PLY: ~30 bytes per vertex or face line; binary PLY: ~12 per vertex, 13 per face
    size = path.stat().st_size
    check_memory(size // 13, size // 12, path.name)
    try:
        loaded = trimesh.load(str(path), force="scene", process=False)
    except UserError:
        raise
    except Exception as e:  # noqa: BLE001 - trimesh raises many types for malformed files
        raise UserError(f"{path.name}: cannot parse {path.suffix} file ({type(e).__name__}: {e})") from None
    pos, nrm, uvs, idx, mid, mats = [], [], [], [], [], []
    count = 0
    try:
        items = loaded.dump(concatenate=False)
    except Exception as e:  # noqa: BLE001
        raise UserError(f"{path.name}: cannot parse {path.suffix} file ({type(e).__name__}: {e})") from None
    for k, geom in enumerate(items):
        if not hasattr(geom, "faces") or len(geom.faces) == 0:
            continue
        p = np.asarray(geom.vertices, np.float32)
        f = np.asarray(geom.faces, np.int64)
        if f.min() < 0 or f.max() >= p.shape[0]:
            raise UserError(f"{path.name}: face indices out of range")
        try:  # the file's normals where it has them, else trimesh's smoothed face normals
            n = np.asarray(geom.vertex_normals, np.float32)
        except Exception:  # noqa: BLE001
            n = None
        if n is None or n.shape != p.shape:
            n = compute_normals(p, f)
        uv = getattr(geom.visual, "uv", None)
        uv = np.asarray(uv, np.float32)[:, :2] if uv is not None and len(uv) == len(p) else np.zeros((len(p), 2),
                                                                                                      np.float32)
        uv = np.stack([uv[:, 0], 1.0 - uv[:, 1]], 1)  # OBJ's v points up; the model's (glTF) points down
        pos.append(p)
        nrm.append(n)
        uvs.append(uv)
        idx.append(f + count)
        mid.append(np.full(f.shape[0], len(mats), np.int32))
        mats.append(_material_from_trimesh(geom, k))
        count += p.shape[0]
    if not pos:
        raise UserError(f"{path.name}: the file has no triangles")
    scene = Scene(path.stem, np.concatenate(pos), np.concatenate(nrm), np.concatenate(uvs), np.concatenate(idx),
                  np.concatenate(mid), mats, [], Environment("black"), {}, str(path))
    scene.validate()
    return scene
