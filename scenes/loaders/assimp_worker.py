"""The Assimp importer in a process of its own (scenes/loaders/assimp.py starts it): reads one
scene file and writes what rtlab needs into an .npz: the triangles in world space (positions,
normals, uvs, indices, material per triangle), through assimp-py (a self-contained Assimp whose
C++ binding hands back arrays), and as JSON the materials (the numbers and the texture paths
the file names), lights and cameras with their world transforms, through pyassimp (Assimp's own
binding over the system's libassimp, whose raw structures have all of them).
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


def _material(props: dict) -> dict:
    out: dict = {"textures": {}, "unused_textures": []}
    for (key, semantic), value in dict.items(props):
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


def _matrix(m) -> np.ndarray:
    """A pyassimp Matrix4x4 (rows a..d, columns 1..4) as numpy."""
    return np.array([[getattr(m, f"{r}{c}") for c in "1234"] for r in "abcd"], np.float64)


def _text(s) -> str:
    return bytes(s.data[:s.length]).decode("utf-8", "replace")


def _world(root, matrix, children) -> dict:
    """node name -> (node, its world matrix), depth first without recursion; matrix(node) its
    local matrix, children(node) its children."""
    out, todo = {}, [(root, np.eye(4))]
    while todo:
        node, parent = todo.pop()
        m = parent @ matrix(node)
        out.setdefault(node_name(node), (node, m))
        todo.extend((c, m) for c in reversed(children(node)))
    return out


def node_name(node) -> str:
    return node.name if hasattr(node, "name") and isinstance(node.name, str) else _text(node.mName)


def read_metadata(path: str, flags: int) -> dict:
    """The materials, lights and cameras (in world space) through pyassimp's raw structures: its
    own conversion of every mesh into Python objects is slow (18 s for 1.3 M triangles)."""
    from pyassimp.core import _assimp_lib, _get_properties

    model = _assimp_lib.load(path.encode(sys.getfilesystemencoding()), flags)
    if not model:
        raise RuntimeError("cannot import the file")
    try:
        sc = model.contents
        nodes = _world(sc.mRootNode.contents, lambda n: _matrix(n.mTransformation),
                       lambda n: [n.mChildren[i].contents for i in range(n.mNumChildren)])
        materials = []
        for i in range(sc.mNumMaterials):
            mat = sc.mMaterials[i].contents
            materials.append(_material(_get_properties(mat.mProperties, mat.mNumProperties)))
        lights, features = [], set()
        for i in range(sc.mNumLights):
            li = sc.mLights[i].contents
            name = _text(li.mName)
            m = nodes.get(name, (None, np.eye(4)))[1]
            kind = LIGHT_KINDS.get(int(li.mType))
            if kind is None:
                features.add("area or ambient lights (left out)")
                continue
            v3 = lambda v: np.array([v.x, v.y, v.z], np.float64)  # noqa: E731
            p = m @ np.append(v3(li.mPosition), 1.0)
            c = li.mColorDiffuse
            lights.append({"kind": kind, "name": name, "position": p[:3].tolist(),
                           "direction": (m[:3, :3] @ v3(li.mDirection)).tolist(), "color": [c.r, c.g, c.b],
                           "inner": float(li.mAngleInnerCone), "outer": float(li.mAngleOuterCone)})
        cameras = []
        for i in range(sc.mNumCameras):
            cam = sc.mCameras[i].contents
            name = _text(cam.mName)
            m = nodes.get(name, (None, np.eye(4)))[1]
            v3 = lambda v: np.array([v.x, v.y, v.z], np.float64)  # noqa: E731
            eye = m @ np.append(v3(cam.mPosition), 1.0)
            cameras.append({"name": name, "eye": eye[:3].tolist(), "look": (m[:3, :3] @ v3(cam.mLookAt)).tolist(),
                            "up": (m[:3, :3] @ v3(cam.mUp)).tolist(), "hfov": float(cam.mHorizontalFOV),
                            "aspect": float(cam.mAspect)})
        if sc.mNumAnimations:
            features.add("animation (the first frame's pose is drawn)")
        return {"materials": materials, "lights": lights, "cameras": cameras, "features": features,
                "material_names": [m.get("name", "") for m in materials], "embedded": _embedded(sc)}
    finally:
        _assimp_lib.release(model)


def _embedded(sc) -> list[tuple[dict, np.ndarray]]:
    """The textures the file carries (aiScene.mTextures: FBX's embedded media, glTF's images), as
    ({name, hint}, bytes): a compressed image's file (PNG, JPEG, DDS..., hint its format), or
    (hint "rgba8", shape) the decoded texels, Assimp's BGRA made RGBA."""
    import ctypes

    out = []
    for i in range(sc.mNumTextures):
        t = sc.mTextures[i].contents
        name, hint = _text(t.mFilename), bytes(t.achFormatHint).split(b"\0")[0].decode("ascii", "replace").lower()
        if t.mHeight == 0:  # mWidth bytes of an image file
            data = np.frombuffer(ctypes.string_at(t.pcData, t.mWidth), np.uint8).copy()
            out.append(({"name": name, "hint": hint}, data))
        else:
            texels = np.frombuffer(ctypes.string_at(t.pcData, 4 * t.mWidth * t.mHeight), np.uint8)
            rgba = texels.reshape(t.mHeight, t.mWidth, 4)[..., [2, 1, 0, 3]].copy()
            out.append(({"name": name, "hint": "rgba8", "shape": list(rgba.shape)}, rgba.reshape(-1)))
    return out


def read_geometry(path: str) -> tuple[dict, list[str], set]:
    """The triangles in world space through assimp-py (Assimp in C++, arrays without a Python
    loop), walking its node tree; and the names of the materials its meshes index."""
    import assimp_py as ai

    flags = (ai.Process_Triangulate | ai.Process_GenSmoothNormals | ai.Process_JoinIdenticalVertices
             | ai.Process_SortByPType | ai.Process_ValidateDataStructure)
    sc = ai.import_file(path, flags)
    meshes = sc.meshes
    nodes = _world(sc.root_node, lambda n: np.asarray(n.transformation, np.float64).reshape(4, 4),
                   lambda n: list(n.children))
    pos, nrm, uvs, idx, mid = [], [], [], [], []
    count, features = 0, set()
    for _, (node, m) in nodes.items():
        for k in node.mesh_indices:
            mesh = meshes[k]
            if not mesh.num_faces or mesh.num_indices != 3 * mesh.num_faces:
                continue  # points and lines carry no surface
            v = np.frombuffer(mesh.vertices, np.float32).reshape(-1, 3).astype(np.float64)
            n = np.frombuffer(mesh.normals, np.float32).reshape(-1, 3).astype(np.float64) \
                if mesh.normals is not None else np.zeros_like(v)
            tc = mesh.texcoords or []
            t = np.asarray(tc[0], np.float32).reshape(len(v), -1)[:, :2] if tc else np.zeros((len(v), 2))
            if len(tc) > 1:
                features.add("multiple UV sets (the first is used)")
            cof = np.linalg.inv(m[:3, :3]).T if abs(np.linalg.det(m[:3, :3])) > 1e-30 else m[:3, :3]
            tri = np.frombuffer(mesh.indices, np.uint32).reshape(-1, 3).astype(np.int64)
            if np.linalg.det(m[:3, :3]) < 0:
                tri = tri[:, [0, 2, 1]]
            pos.append(v @ m[:3, :3].T + m[:3, 3])
            nrm.append(n @ cof.T)
            uvs.append(np.stack([t[:, 0], 1.0 - t[:, 1]], 1))  # Assimp's v points up, the model's down
            idx.append(tri + count)
            mid.append(np.full(len(tri), int(mesh.material_index), np.int64))
            count += len(v)
    cat = (lambda a, shape: np.concatenate(a) if a else np.zeros(shape))  # noqa: E731
    arrays = {"positions": cat(pos, (0, 3)).astype(np.float32), "normals": cat(nrm, (0, 3)).astype(np.float32),
              "uvs": cat(uvs, (0, 2)).astype(np.float32), "indices": cat(idx, (0, 3)).astype(np.int64),
              "material_ids": cat(mid, (0,)).astype(np.int64)}
    return arrays, [str(m.get("NAME", "")) for m in sc.materials], features


def read(path: str) -> tuple[dict, dict]:
    from concurrent.futures import ThreadPoolExecutor

    from pyassimp import postprocess as pp

    with ThreadPoolExecutor(1) as pool:  # both parse the file; pyassimp's native call leaves the GIL to the other
        later = pool.submit(read_metadata, path, pp.aiProcess_ValidateDataStructure)
        arrays, names, features = read_geometry(path)
        meta = later.result()
    mine = meta.pop("material_names")
    carried, meta["embedded"] = meta.pop("embedded"), []
    for i, (info, data) in enumerate(carried):
        arrays[f"embedded_{i}"] = data
        meta["embedded"].append(info)
    if names != mine:  # the two readers (two Assimp versions) list materials differently: match by name
        remap = []
        for n in names:
            if n not in mine:  # one the metadata reader does not have: a plain material of that name
                mine.append(n)
                meta["materials"].append({"name": n, "textures": {}, "unused_textures": []})
            remap.append(mine.index(n))
        arrays["material_ids"] = np.asarray(remap or [0], np.int64)[arrays["material_ids"]]
    meta["features"] = sorted(features | meta["features"])
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
        import assimp_py  # noqa: F401
        import pyassimp
        import pyassimp.errors
    except Exception as e:  # noqa: BLE001 - a missing library shows as many kinds of error
        print(f"Assimp is not installed ({type(e).__name__}: {str(e)[:80]}): apt install libassimp5, "
              "pip install pyassimp assimp-py", file=sys.stderr)
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
