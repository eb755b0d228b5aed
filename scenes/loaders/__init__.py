"""Load a scene by built-in name or file path (.gltf, .glb, .obj, .ply). Files are read by
rtlab's own readers, which check every value before use (scenes/loaders/checks.py)."""
from __future__ import annotations

import warnings
from pathlib import Path

from core.errors import UserError

EXTENSIONS = (".gltf", ".glb", ".obj", ".ply")


def load_scene(spec: str):
    """Built-in name (optionally `name:detail`) or a path. Raises UserError with one clear line."""
    scene = _load(spec)
    if not scene.has_light:
        warnings.warn(f"{scene.name}: no lights and no emissive surfaces: only the environment (env=...) and "
                      "ambient occlusion will show", stacklevel=2)
    return scene


def _load(spec: str):
    from scenes.builtin import BUILTINS, build_builtin, is_builtin

    if is_builtin(spec):
        return build_builtin(spec)
    path = Path(spec)
    ext = path.suffix.lower()
    if ext not in EXTENSIONS:
        if not path.suffix and not path.exists():
            raise UserError(f"unknown scene {spec!r}: not a built-in ({', '.join(BUILTINS)}) and not a file path")
        raise UserError(f"{path.name}: unsupported file type {ext or '(none)'!r}; use {', '.join(EXTENSIONS)}")
    try:
        is_file, exists = path.is_file(), path.exists()
    except (OSError, ValueError) as e:  # a name too long, a NUL in it...
        raise UserError(f"{spec[:120]}: cannot use this path ({getattr(e, 'strerror', None) or e})") from None
    if not exists:
        raise UserError(f"{spec[:200]}: no such file")
    if not is_file:
        raise UserError(f"{spec[:200]}: not a file")
    if ext in (".gltf", ".glb"):
        from scenes.loaders.gltf import load_gltf

        return load_gltf(path)
    if ext == ".obj":
        from scenes.loaders.obj import load_obj

        return load_obj(path)
    from scenes.loaders.ply import load_ply

    return load_ply(path)
