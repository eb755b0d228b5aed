"""glTF 2.0 / GLB reader that keeps what trimesh drops: KHR_lights_punctual,
KHR_materials_emissive_strength, cameras, double-sidedness.

Buffers and images may only come from data URIs, the GLB's binary chunk, or files inside
the scene's own folder: a scene file must not read arbitrary files.
"""
from __future__ import annotations

import base64
import json
import struct
from pathlib import Path
from urllib.parse import unquote

import numpy as np

from core.errors import UserError
from scenes.loaders.common import check_memory, compute_normals, decode_image, safe_child
from scenes.model import Environment, Light, Material, Scene, View

COMPONENT = {5120: np.int8, 5121: np.uint8, 5122: np.int16, 5123: np.uint16, 5125: np.uint32, 5126: np.float32}
WIDTH = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT2": 4, "MAT3": 9, "MAT4": 16}
GLB_MAGIC = 0x46546C67


def load_gltf(path: Path) -> Scene:
    data = path.read_bytes()
    if path.suffix.lower() == ".glb":
        doc, bin_chunk = _split_glb(data, path)
    else:
        try:
            doc = json.loads(data.decode("utf-8"))
        except (UnicodeDecodeError, json.JSONDecodeError) as e:
            raise UserError(f"{path.name}: malformed glTF JSON ({e})") from None
        bin_chunk = None
    if not isinstance(doc, dict) or "asset" not in doc:
        raise UserError(f"{path.name}: not a glTF document (no 'asset')")
    try:
        return _Reader(doc, bin_chunk, path).scene()
    except UserError:
        raise
    except (KeyError, IndexError, TypeError, ValueError, AttributeError, struct.error) as e:
        raise UserError(f"{path.name}: malformed glTF ({type(e).__name__}: {e})") from None


def _split_glb(data: bytes, path: Path):
    if len(data) < 20:
        raise UserError(f"{path.name}: truncated GLB (only {len(data)} bytes)")
    magic, version, length = struct.unpack_from("<III", data, 0)
    if magic != GLB_MAGIC:
        raise UserError(f"{path.name}: not a GLB file (bad magic)")
    if version != 2:
        raise UserError(f"{path.name}: GLB version {version} is not supported (need 2)")
    if length > len(data):
        raise UserError(f"{path.name}: truncated GLB ({len(data)} of {length} bytes)")
    offset, doc, binary = 12, None, None
    while offset + 8 <= length:
        clen, ctype = struct.unpack_from("<II", data, offset)
        chunk = data[offset + 8: offset + 8 + clen]
        if len(chunk) != clen:
            raise UserError(f"{path.name}: truncated GLB chunk")
        if ctype == 0x4E4F534A:
            try:
                doc = json.loads(chunk.decode("utf-8"))
            except (UnicodeDecodeError, json.JSONDecodeError) as e:
                raise UserError(f"{path.name}: malformed GLB JSON chunk ({e})") from None
        elif ctype == 0x004E4942:
            binary = chunk
        offset += 8 + clen
    if doc is None:
        raise UserError(f"{path.name}: GLB has no JSON chunk")
    return doc, binary


def _node_matrix(node: dict) -> np.ndarray:
    if "matrix" in node:
        return np.asarray(node["matrix"], float).reshape(4, 4).T  # column-major in the file
    t = np.asarray(node.get("translation", (0, 0, 0)), float)
    x, y, z, w = np.asarray(node.get("rotation", (0, 0, 0, 1)), float)
    s = np.asarray(node.get("scale", (1, 1, 1)), float)
    r = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                  [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                  [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])
    m = np.eye(4)
    m[:3, :3] = r * s[None, :]
    m[:3, 3] = t
    return m


class _Reader:
    def __init__(self, doc: dict, bin_chunk: bytes | None, path: Path):
        self.doc, self.bin, self.path = doc, bin_chunk, path
        self._buffers: dict[int, bytes] = {}
        self._textures: dict[int, np.ndarray | None] = {}

    # -- raw data --------------------------------------------------------------------------
    def _uri_bytes(self, uri: str) -> bytes:
        if uri.startswith("data:"):
            head, _, payload = uri.partition(",")
            if ";base64" not in head:
                raise UserError(f"{self.path.name}: only base64 data URIs are supported")
            try:
                return base64.b64decode(payload, validate=False)
            except ValueError as e:
                raise UserError(f"{self.path.name}: bad base64 data URI ({e})") from None
        target = safe_child(self.path, unquote(uri))
        try:
            return target.read_bytes()
        except OSError as e:
            raise UserError(f"{self.path.name}: cannot read {uri!r}: {e.strerror}") from None

    def buffer(self, i: int) -> bytes:
        if i not in self._buffers:
            b = self.doc["buffers"][i]
            if "uri" in b:
                data = self._uri_bytes(b["uri"])
            elif self.bin is not None:
                data = self.bin
            else:
                raise UserError(f"{self.path.name}: buffer {i} has no data")
            if len(data) < b.get("byteLength", 0):
                raise UserError(f"{self.path.name}: buffer {i} is truncated ({len(data)} of {b['byteLength']} bytes)")
            self._buffers[i] = data
        return self._buffers[i]

    def view_bytes(self, i: int) -> bytes:
        v = self.doc["bufferViews"][i]
        data = self.buffer(v["buffer"])
        start, length = v.get("byteOffset", 0), v["byteLength"]
        if start + length > len(data):
            raise UserError(f"{self.path.name}: bufferView {i} runs past its buffer")
        return data[start:start + length]

    def accessor(self, i: int) -> np.ndarray:
        a = self.doc["accessors"][i]
        if "sparse" in a:
            raise UserError(f"{self.path.name}: sparse accessors are not supported")
        dtype = np.dtype(COMPONENT[a["componentType"]])
        width, count = WIDTH[a["type"]], a["count"]
        if "bufferView" not in a:
            return np.zeros((count, width), np.float32)
        view = self.doc["bufferViews"][a["bufferView"]]
        raw = self.view_bytes(a["bufferView"])
        offset = a.get("byteOffset", 0)
        stride = view.get("byteStride") or dtype.itemsize * width
        need = offset + (count - 1) * stride + dtype.itemsize * width if count else 0
        if need > len(raw):
            raise UserError(f"{self.path.name}: accessor {i} runs past its bufferView")
        arr = np.ndarray((count, width), dtype, raw, offset, (stride, dtype.itemsize)).copy()
        if a.get("normalized") and dtype.kind in "iu":
            arr = arr.astype(np.float32) / np.iinfo(dtype).max
        return arr

    def texture(self, index: int) -> np.ndarray | None:
        if index not in self._textures:
            tex = self.doc["textures"][index]
            src = tex.get("source")
            img = self.doc["images"][src] if src is not None else None
            data = None
            if img is not None:
                if "bufferView" in img:
                    data = self.view_bytes(img["bufferView"])
                elif "uri" in img:
                    data = self._uri_bytes(img["uri"])
            self._textures[index] = decode_image(data, f"{self.path.name}: texture {index}") if data else None
        return self._textures[index]

    # -- scene -----------------------------------------------------------------------------
    def materials(self) -> list[Material]:
        out = []
        for k, m in enumerate(self.doc.get("materials", [])):
            pbr = m.get("pbrMetallicRoughness", {})
            strength = m.get("extensions", {}).get("KHR_materials_emissive_strength", {}).get("emissiveStrength", 1.0)
            emissive = np.asarray(m.get("emissiveFactor", (0, 0, 0)), float) * float(strength)
            tex = None
            if "baseColorTexture" in pbr:
                tex = self.texture(pbr["baseColorTexture"]["index"])
            out.append(Material(
                name=m.get("name", f"material_{k}"),
                base_color=tuple(float(c) for c in pbr.get("baseColorFactor", (1, 1, 1, 1))),
                texture=tex,
                roughness=float(np.clip(pbr.get("roughnessFactor", 1.0), 0.0, 1.0)),
                metallic=float(np.clip(pbr.get("metallicFactor", 1.0), 0.0, 1.0)),
                emissive=tuple(float(e) for e in emissive),
                double_sided=bool(m.get("doubleSided", False)),
            ))
        out.append(Material("gltf_default", (1, 1, 1, 1), None, 1.0, 1.0))  # glTF's default material
        return out

    def estimate(self) -> tuple[int, int]:
        """Triangles and vertices the file would expand to (instances counted), from its JSON."""
        doc = self.doc
        per_mesh = []
        for mesh in doc.get("meshes", []):
            tris = verts = 0
            for prim in mesh.get("primitives", []):
                if prim.get("mode", 4) != 4:
                    continue
                v = int(doc["accessors"][prim["attributes"]["POSITION"]]["count"])
                i = int(doc["accessors"][prim["indices"]]["count"]) if "indices" in prim else v
                tris, verts = tris + i // 3, verts + v
            per_mesh.append((tris, verts))
        tris = sum(per_mesh[n["mesh"]][0] for n in doc.get("nodes", []) if "mesh" in n)
        verts = sum(per_mesh[n["mesh"]][1] for n in doc.get("nodes", []) if "mesh" in n)
        return tris, verts

    def scene(self) -> Scene:
        doc = self.doc
        check_memory(*self.estimate(), self.path.name)
        mats = self.materials()
        default_mat = len(mats) - 1
        pos, nrm, uvs, idx, mid = [], [], [], [], []
        lights, views = [], {}
        light_defs = doc.get("extensions", {}).get("KHR_lights_punctual", {}).get("lights", [])
        count = 0

        def visit(node_index: int, parent: np.ndarray, depth: int):
            nonlocal count
            if depth > 64:
                raise UserError(f"{self.path.name}: node hierarchy too deep or cyclic")
            node = doc["nodes"][node_index]
            m = parent @ _node_matrix(node)
            if "mesh" in node:
                for prim in doc["meshes"][node["mesh"]]["primitives"]:
                    if prim.get("mode", 4) != 4:
                        continue  # points and lines carry no surface
                    attrs = prim["attributes"]
                    p = self.accessor(attrs["POSITION"]).astype(np.float32)
                    if not np.isfinite(p).all() or not np.isfinite(m).all():
                        raise UserError(f"{self.path.name}: non-finite vertex positions in mesh {node['mesh']}")
                    if "indices" in prim:
                        tri = self.accessor(prim["indices"]).astype(np.int64).reshape(-1, 3)
                    else:
                        tri = np.arange(p.shape[0] - p.shape[0] % 3).reshape(-1, 3)
                    if tri.size and (tri.min() < 0 or tri.max() >= p.shape[0]):
                        raise UserError(f"{self.path.name}: triangle indices out of range in mesh {node['mesh']}")
                    n = self.accessor(attrs["NORMAL"]).astype(np.float32) if "NORMAL" in attrs else None
                    t = self.accessor(attrs["TEXCOORD_0"]).astype(np.float32) if "TEXCOORD_0" in attrs \
                        else np.zeros((p.shape[0], 2), np.float32)
                    wp = p @ m[:3, :3].T + m[:3, 3]
                    if n is None:
                        wn = compute_normals(wp, tri)
                    else:
                        wn = n @ np.linalg.inv(m[:3, :3])
                    if np.linalg.det(m[:3, :3]) < 0:
                        tri = tri[:, [0, 2, 1]]
                    pos.append(wp)
                    nrm.append(wn)
                    uvs.append(t[:, :2])
                    idx.append(tri + count)
                    mid.append(np.full(tri.shape[0], prim.get("material", default_mat), np.int32))
                    count += p.shape[0]
            ext = node.get("extensions", {}).get("KHR_lights_punctual")
            if ext is not None:
                lights.append(self._light(light_defs[ext["light"]], m))
            if "camera" in node:
                cam = doc["cameras"][node["camera"]]
                if cam.get("type") == "perspective":
                    name = cam.get("name") or node.get("name") or f"camera_{len(views)}"
                    eye = m[:3, 3]
                    fwd = -m[:3, 2] / max(np.linalg.norm(m[:3, 2]), 1e-12)
                    up = m[:3, 1] / max(np.linalg.norm(m[:3, 1]), 1e-12)
                    views[name] = View(name, tuple(map(float, eye)), tuple(map(float, eye + fwd)),
                                       tuple(map(float, up)), float(np.degrees(cam["perspective"]["yfov"])))
            for child in node.get("children", []):
                visit(child, m, depth + 1)

        scene_index = doc.get("scene", 0)
        if doc.get("scenes"):
            roots = doc["scenes"][scene_index].get("nodes", [])
        else:
            roots = range(len(doc.get("nodes", [])))
        for r in roots:
            visit(r, np.eye(4), 0)
        if not pos:
            raise UserError(f"{self.path.name}: the file has no triangle meshes")
        scene = Scene(self.path.stem, np.concatenate(pos), np.concatenate(nrm), np.concatenate(uvs),
                      np.concatenate(idx), np.concatenate(mid), mats, lights, Environment("black"), views,
                      str(self.path))
        scene.validate()
        return scene

    def _light(self, d: dict, m: np.ndarray) -> Light:
        kind = d.get("type")
        color = tuple(float(c) for c in d.get("color", (1, 1, 1)))
        intensity = float(d.get("intensity", 1.0))
        axis = -m[:3, 2]
        axis = axis / max(np.linalg.norm(axis), 1e-12)
        common = dict(color=color, intensity=intensity, position=tuple(map(float, m[:3, 3])),
                      direction=tuple(map(float, axis)), name=d.get("name", ""))
        if kind == "directional":
            return Light(kind="directional", **common)
        if kind == "point":
            return Light(kind="point", **common)
        if kind == "spot":
            spot = d.get("spot", {})
            return Light(kind="spot", inner_cone=float(spot.get("innerConeAngle", 0.0)),
                         outer_cone=float(spot.get("outerConeAngle", np.pi / 4)), **common)
        raise UserError(f"{self.path.name}: unknown light type {kind!r}")

