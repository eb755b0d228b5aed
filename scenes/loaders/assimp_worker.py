"""The Assimp importer in a process of its own (scenes/loaders/assimp.py starts it): reads one
scene file with pyassimp (Assimp's own Python binding over the system's libassimp), walks its
node hierarchy and writes what rtlab needs into an .npz: the triangles in world space
(positions, normals, uvs, indices, material per triangle) and, as JSON, the materials (the
numbers and the texture paths the file names), lights and cameras with their world transforms.
A crash, an abort or a hang in the native importer ends this process, not the viewer; a failure
prints one line on stderr and exits non-zero.

    python -m scenes.loaders.assimp_worker SCENE_FILE OUT.npz
"""
from __future__ import annotations

import json
import sys

import numpy as np

# aiTextureType: the layers rtlab reads (the others are reported as unused)
TEXTURE_TYPES = {1: "diffuse", 4: "emissive", 5: "height", 6: "normals", 8: "opacity", 12: "base_color",
                 14: "emission_color", 15: "metalness", 16: "roughness", 17: "occlusion"}
LIGHT_KINDS = {1: "directional", 2: "point", 3: "spot"}
NUMBERS = ("diffuse", "emissive", "opacity", "shininess", "metallicFactor", "roughnessFactor", "base",
           "twosided", "shadingm", "Diffuse", "Emissive")  # capitalised: FBX's legacy properties, as read


def _material(m) -> dict:
    props = dict.items(m.properties)
    out: dict = {"textures": {}, "unused_textures": []}
    for (key, semantic), value in props:
        if key == "name":
            out["name"] = str(value)
        elif key == "file" and semantic:
            name = TEXTURE_TYPES.get(int(semantic))
            (out["textures"].__setitem__(name, str(value)) if name else out["unused_textures"].append(int(semantic)))
        elif key in NUMBERS and not semantic:
            v = np.asarray(value, np.float64).reshape(-1) if not isinstance(value, bytes) else \
                np.frombuffer(value[:4].ljust(4, b"\0"), np.int32).astype(np.float64)
            out[key] = [float(x) for x in v[:4]]
    return out


def _world_matrices(root) -> dict:
    """node name -> (node, its world matrix), depth first without recursion."""
    out, todo = {}, [(root, np.eye(4))]
    while todo:
        node, parent = todo.pop()
        m = parent @ np.asarray(node.transformation, np.float64).reshape(4, 4)
        out.setdefault(node.name, (node, m))
        todo.extend((c, m) for c in reversed(node.children))
    return out


def read(path: str) -> tuple[dict, dict]:
    import pyassimp
    from pyassimp import postprocess as pp

    flags = (pp.aiProcess_Triangulate | pp.aiProcess_GenSmoothNormals | pp.aiProcess_JoinIdenticalVertices
             | pp.aiProcess_SortByPType | pp.aiProcess_ValidateDataStructure)
    with pyassimp.load(path, processing=flags) as sc:
        meshes = list(sc.meshes)
        index = {id(m): k for k, m in enumerate(meshes)}
        nodes = _world_matrices(sc.rootnode)
        pos, nrm, uvs, idx, mid = [], [], [], [], []
        count, features = 0, set()
        for _, (node, m) in nodes.items():
            for mesh in node.meshes:
                k = index.get(id(mesh))
                mesh = meshes[k] if k is not None else mesh
                faces = np.asarray(mesh.faces)
                if faces.ndim != 2 or faces.shape[1] != 3 or not len(faces):
                    continue  # points and lines carry no surface
                v = np.asarray(mesh.vertices, np.float64)
                n = np.asarray(mesh.normals, np.float64) if len(mesh.normals) else np.zeros_like(v)
                tc = np.asarray(mesh.texturecoords)
                t = tc[0][:, :2] if tc.size else np.zeros((len(v), 2))
                if tc.ndim == 3 and tc.shape[0] > 1:
                    features.add("multiple UV sets (the first is used)")
                if getattr(mesh, "bones", None):
                    features.add("skinning (the bind pose is drawn)")
                cof = np.linalg.inv(m[:3, :3]).T if abs(np.linalg.det(m[:3, :3])) > 1e-30 else m[:3, :3]
                wp = v @ m[:3, :3].T + m[:3, 3]
                wn = n @ cof.T
                tri = faces.astype(np.int64)
                if np.linalg.det(m[:3, :3]) < 0:
                    tri = tri[:, [0, 2, 1]]
                pos.append(wp)
                nrm.append(wn)
                uvs.append(np.stack([t[:, 0], 1.0 - t[:, 1]], 1))  # Assimp's v points up, the model's down
                idx.append(tri + count)
                mid.append(np.full(len(tri), int(mesh.materialindex), np.int64))
                count += len(v)
        if getattr(sc, "animations", None):
            features.add("animation (the first frame's pose is drawn)")
        lights = []
        for li in sc.lights:
            node_m = nodes.get(li.name, (None, np.eye(4)))[1]
            kind = LIGHT_KINDS.get(int(li.type))
            if kind is None:
                features.add("area or ambient lights")
                continue
            p = node_m @ np.append(np.asarray(li.position, np.float64), 1.0)
            d = node_m[:3, :3] @ np.asarray(li.direction, np.float64)
            lights.append({"kind": kind, "name": str(li.name), "position": p[:3].tolist(), "direction": d.tolist(),
                           "color": np.asarray(li.color_diffuse, np.float64).tolist(),
                           "inner": float(li.angleinnercone), "outer": float(li.angleoutercone)})
        cameras = []
        for c in sc.cameras:
            node_m = nodes.get(c.name, (None, np.eye(4)))[1]
            eye = node_m @ np.append(np.asarray(c.position, np.float64), 1.0)
            look = node_m[:3, :3] @ np.asarray(c.lookat, np.float64)
            up = node_m[:3, :3] @ np.asarray(c.up, np.float64)
            cameras.append({"name": str(c.name), "eye": eye[:3].tolist(), "look": look.tolist(), "up": up.tolist(),
                            "hfov": float(c.horizontalfov), "aspect": float(c.aspect)})
        meta = {"materials": [_material(m) for m in sc.materials], "lights": lights, "cameras": cameras,
                "features": sorted(features)}
    cat = (lambda a, shape: np.concatenate(a) if a else np.zeros(shape))  # noqa: E731
    arrays = {"positions": cat(pos, (0, 3)).astype(np.float32), "normals": cat(nrm, (0, 3)).astype(np.float32),
              "uvs": cat(uvs, (0, 2)).astype(np.float32), "indices": cat(idx, (0, 3)).astype(np.int64),
              "material_ids": cat(mid, (0,)).astype(np.int64)}
    return arrays, meta


def _reason(e: BaseException) -> str:
    """Assimp's own last error where it has one (pyassimp's exception says only that it failed)."""
    try:
        from pyassimp.core import _assimp_lib

        _assimp_lib.dll.aiGetErrorString.restype = __import__("ctypes").c_char_p
        text = (_assimp_lib.dll.aiGetErrorString() or b"").decode("utf-8", "replace").strip()
    except Exception:  # noqa: BLE001 - the reason is a courtesy
        text = ""
    return (text or str(e) or type(e).__name__).splitlines()[0][:160]


def main(argv: list[str]) -> int:
    src, out = argv
    try:
        import pyassimp
        import pyassimp.errors
    except Exception as e:  # noqa: BLE001 - a missing library shows as many kinds of error
        print(f"Assimp is not installed ({type(e).__name__}): apt install libassimp5 and pip install pyassimp",
              file=sys.stderr)
        return 3
    try:
        arrays, meta = read(src)
    except (Exception, pyassimp.errors.AssimpError) as e:  # noqa: BLE001 - one line for the parent
        print(f"Assimp cannot read it: {_reason(e)}", file=sys.stderr)
        return 2
    np.savez(out, meta=np.frombuffer(json.dumps(meta).encode(), np.uint8), **arrays)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
