"""Load a scene by built-in name or file path (.gltf, .glb, .obj, .ply; .fbx and Assimp's other
formats). glTF, OBJ and PLY are read by rtlab's own readers, which check every value before use
(scenes/loaders/checks.py); FBX and the rest by Assimp in a child process (scenes/loaders/
assimp.py), whose arrays are checked the same way; a file with no lights of its own opens under
the studio environment."""
from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

from core.errors import UserError
from scenes.builtin import is_builtin
from scenes.cache import load_cached
from scenes.loaders.assimp import EXTENSIONS as ASSIMP_EXTENSIONS
from scenes.model import Environment
from scenes.progress import stage

EXTENSIONS = (".gltf", ".glb", ".obj", ".ply") + ASSIMP_EXTENSIONS


def load_scene(spec: str):
    """Built-in name (optionally `name:detail`) or a path. Raises UserError with one clear line."""
    stage(f"reading {Path(spec).name if not is_builtin(spec) else spec}")
    scene = _load(spec)
    if not is_builtin(spec) and scene.environment.kind == "black" and not lit_by_itself(scene):
        # as the glTF sample viewer and Blender light an asset: under an environment
        scene.environment = Environment("studio")
        warnings.warn(f"{scene.name}: no lights of its own: env=scene lights it with the built-in studio "
                      "environment (env=black for none)", stacklevel=2)
    elif not scene.has_light:
        warnings.warn(f"{scene.name}: no lights and no emissive surfaces: only the environment (env=...) and "
                      "ambient occlusion will show", stacklevel=2)
    return scene


def lit_by_itself(scene) -> bool:
    """Whether a scene has lights of its own: punctual lights, or surfaces of a constant
    emission (a lamp's, a window's). Emission painted by a texture alone (decals, screens, as
    on the Khronos DamagedHelmet) does not light a scene."""
    used = set(np.unique(scene.material_ids).tolist()) if scene.material_ids.size else set()
    return bool(scene.lights) or any(m.is_emissive and m.emissive_map is None
                                     for k, m in enumerate(scene.materials) if k in used)


def _load(spec: str):
    from scenes.builtin import BUILTINS, build_builtin

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
        from scenes.loaders.gltf import load_gltf as read
    elif ext == ".obj":
        from scenes.loaders.obj import load_obj as read
    elif ext == ".ply":
        from scenes.loaders.ply import load_ply as read
    else:
        from scenes.loaders.assimp import load_assimp as read
    return load_cached(path, read)  # big files: read once, then from rtlab's cache
