"""glTF 2.0 / GLB reader that keeps what trimesh drops: KHR_lights_punctual,
KHR_materials_emissive_strength, cameras, double-sidedness.

Buffers and images may only come from data URIs, the GLB's binary chunk, or files inside
the scene's own folder: a scene file must not read arbitrary files.
"""
from __future__ import annotations

import base64
import json
import struct
import warnings
from pathlib import Path
from urllib.parse import unquote

import numpy as np

from core.errors import UserError
from scenes.loaders.checks import Checker, read_regular
from scenes.loaders.common import check_memory, compute_normals, decode_image, safe_child
from scenes.loaders.gltf_checks import WIDTH, check_document
from scenes.loaders.gltf_materials import UvRule, generate_tangents, read_material, wrap_modes
from scenes.model import Environment, Light, Material, Scene, View
from scenes.progress import counted, stage

COMPONENT = {5120: np.int8, 5121: np.uint8, 5122: np.int16, 5123: np.uint16, 5125: np.uint32, 5126: np.float32}
GLB_MAGIC = 0x46546C67


def load_gltf(path: Path) -> Scene:
    data = read_regular(path, path.name)
    if path.suffix.lower() == ".glb":
        doc, bin_chunk = _split_glb(data, path)
    else:
        doc = _parse_json(data, path, "glTF JSON")
        bin_chunk = None
    if not isinstance(doc, dict) or "asset" not in doc:
        raise UserError(f"{path.name}: not a glTF document (no 'asset')")
    roots = check_document(doc, Checker(path.name))
    with np.errstate(all="ignore"):  # overflow shows as non-finite values, checked where used
        return _Reader(doc, bin_chunk, path).scene(roots)


def _parse_json(data: bytes, path: Path, what: str):
    try:
        return json.loads(data.decode("utf-8"))
    except RecursionError:
        raise UserError(f"{path.name}: malformed {what} (nested too deeply)") from None
    except (UnicodeDecodeError, ValueError) as e:  # JSONDecodeError, and ints past Python's digit limit
        raise UserError(f"{path.name}: malformed {what} ({str(e)[:200]})") from None


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
            doc = _parse_json(chunk, path, "GLB JSON chunk")
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


def _normal_matrix(m3: np.ndarray) -> np.ndarray:
    """What normals are multiplied by (as rows): the cofactor matrix, which is det(M) M^-T and
    exists for singular M too (a flattened mesh keeps normals), signed so they keep their side."""
    c0, c1, c2 = m3[:, 0], m3[:, 1], m3[:, 2]
    cof = np.stack([np.cross(c1, c2), np.cross(c2, c0), np.cross(c0, c1)], axis=1)
    return (cof if np.linalg.det(m3) >= 0 else -cof).T


class _Reader:
    """Reads a document that check_document has accepted."""

    def __init__(self, doc: dict, bin_chunk: bytes | None, path: Path):
        self.doc, self.bin, self.path = doc, bin_chunk, path
        self._buffers: dict[int, bytes] = {}
        self._textures: dict[tuple, np.ndarray | None] = {}
        self._images: dict[int, bytes | None] = {}
        self._warned: set = set()

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
        return read_regular(safe_child(self.path, unquote(uri)), self.path.name)

    def buffer(self, i: int) -> bytes:
        if i not in self._buffers:
            b = self.doc["buffers"][i]
            if "uri" in b:
                data = self._uri_bytes(b["uri"])
            elif self.bin is not None:
                data = self.bin
            else:
                raise UserError(f"{self.path.name}: buffer {i} has no data")
            if len(data) < b["byteLength"]:
                raise UserError(f"{self.path.name}: buffer {i} is truncated ({len(data)} of {b['byteLength']} bytes)")
            self._buffers[i] = data
        return self._buffers[i]

    def view_bytes(self, i: int) -> memoryview:
        v = self.doc["bufferViews"][i]
        data = self.buffer(v["buffer"])
        start, length = v.get("byteOffset", 0), v["byteLength"]
        if start + length > len(data):
            raise UserError(f"{self.path.name}: bufferView {i} runs past its buffer")
        return memoryview(data)[start:start + length]

    def accessor(self, i: int) -> np.ndarray:
        """The accessor's elements as a (count, width) array; its size was checked against the
        bytes the file holds before anything is allocated."""
        a = self.doc["accessors"][i]
        dtype = np.dtype(COMPONENT[a["componentType"]])
        width, count = WIDTH[a["type"]], a["count"]
        view = self.doc["bufferViews"][a["bufferView"]]
        raw = self.view_bytes(a["bufferView"])
        offset = a.get("byteOffset", 0)
        stride = view.get("byteStride") or dtype.itemsize * width
        if stride < dtype.itemsize * width:
            raise UserError(f"{self.path.name}: accessor {i}: byteStride {stride} is smaller than its elements")
        need = offset + (count - 1) * stride + dtype.itemsize * width
        if need > len(raw):
            raise UserError(f"{self.path.name}: accessor {i} runs past its bufferView")
        arr = np.ndarray((count, width), dtype, raw, offset, (stride, dtype.itemsize)).copy()
        if a.get("normalized") and dtype.kind in "iu":
            arr = arr.astype(np.float32) / np.iinfo(dtype).max
        return arr

    def wrap(self, index: int) -> tuple:
        """The wrap modes (u, v) of texture `index`'s sampler (scenes.model.WRAP_*)."""
        sampler = self.doc["textures"][index].get("sampler")
        return wrap_modes(self.doc["samplers"][sampler] if sampler is not None else {})

    def nearest(self, index: int) -> bool:
        """Whether texture `index`'s sampler magnifies by the nearest texel (magFilter NEAREST)."""
        sampler = self.doc["textures"][index].get("sampler")
        return sampler is not None and self.doc["samplers"][sampler].get("magFilter") == 9728

    def texture(self, index: int, srgb: bool = True, alpha: bool = False) -> np.ndarray | None:
        """A texture as float32 in [0, 1] (colour decoded from sRGB when `srgb`; RGBA when
        `alpha`), or None (with a warning naming the file) if it cannot be read or decoded:
        the material then renders with its factors, as other viewers do."""
        key = (index, srgb, alpha)
        if key not in self._textures:
            src = self.doc["textures"][index].get("source")
            uri = self.doc["images"][src].get("uri", "") if src is not None else ""
            what = f"{self.path.name}: texture {index}" + (f" ({uri[:80]})" if uri else "")
            data = self._image_bytes(src, what) if src is not None else None
            self._textures[key] = decode_image(data, what, srgb, alpha) if data else None
        return self._textures[key]

    def _image_bytes(self, src: int, what: str) -> bytes | None:
        """Image `src`'s bytes, read once however many textures use it; a file that cannot be
        read is a warning (None), one outside the scene's folder an error."""
        if src not in self._images:
            img, data = self.doc["images"][src], None
            if "bufferView" in img:
                data = self.view_bytes(img["bufferView"]).tobytes()
            elif "uri" in img and img["uri"].startswith("data:"):
                data = self._uri_bytes(img["uri"])
            elif "uri" in img:
                target = safe_child(self.path, unquote(img["uri"]))
                try:
                    data = read_regular(target, self.path.name)
                except UserError as e:
                    warnings.warn(f"{what}: {str(e).split(': ', 1)[-1]}; the material renders without it",
                                  stacklevel=3)
            self._images[src] = data
        return self._images[src]

    # -- scene -----------------------------------------------------------------------------
    def materials(self) -> tuple[list[Material], list[UvRule]]:
        mats, rules = [], []
        found = self.doc.get("materials", [])
        for k, m in enumerate(found):
            counted("materials and textures", k, len(found))
            mat, rule = read_material(self, k, m)
            if not np.isfinite(np.float32(max(mat.emissive))):
                raise UserError(f"{self.path.name}: materials[{k}]: emissive radiance is not a finite float32")
            mats.append(mat)
            rules.append(rule)
        mats.append(Material("gltf_default", (1, 1, 1, 1), None, 1.0, 1.0))  # glTF's default material
        rules.append(UvRule())
        return mats, rules

    def _drawn_nodes(self, roots: list[int]) -> list[int]:
        """Every node under the roots (the nodes form trees: check_document)."""
        out, todo = [], list(roots)
        while todo:
            k = todo.pop()
            out.append(k)
            todo.extend(self.doc["nodes"][k].get("children", []))
        return out

    def estimate(self, nodes: list[int]) -> tuple[int, int]:
        """Triangles and vertices the drawn nodes expand to, from the JSON alone."""
        doc = self.doc
        per_mesh = []
        for mesh in doc.get("meshes", []):
            tris = verts = 0
            for prim in mesh["primitives"]:
                if prim.get("mode", 4) != 4:
                    continue
                v = doc["accessors"][prim["attributes"]["POSITION"]]["count"]
                i = doc["accessors"][prim["indices"]]["count"] if "indices" in prim else v
                tris, verts = tris + i // 3, verts + v
            per_mesh.append((tris, verts))
        meshes = [doc["nodes"][k]["mesh"] for k in nodes if "mesh" in doc["nodes"][k]]
        return sum(per_mesh[m][0] for m in meshes), sum(per_mesh[m][1] for m in meshes)

    def scene(self, roots: list[int]) -> Scene:
        doc = self.doc
        check_memory(*self.estimate(self._drawn_nodes(roots)), self.path.name)
        mats, rules = self.materials()
        default_mat = len(mats) - 1
        pos, nrm, uvs, idx, mid, tangents, colors = [], [], [], [], [], [], []
        lights, views = [], {}
        light_defs = doc.get("extensions", {}).get("KHR_lights_punctual", {}).get("lights", [])
        count = 0
        stage("meshes")
        todo = [(r, np.eye(4)) for r in reversed(roots)]
        while todo:  # depth first, in the file's order; no recursion (trees may be deep)
            node_index, parent = todo.pop()
            node = doc["nodes"][node_index]
            m = parent @ _node_matrix(node)
            if not np.isfinite(m).all():
                raise UserError(f"{self.path.name}: nodes[{node_index}]: its transform overflows")
            if "mesh" in node:
                for prim in doc["meshes"][node["mesh"]]["primitives"]:
                    if prim.get("mode", 4) != 4:
                        continue  # points and lines carry no surface
                    material = prim.get("material", default_mat)
                    p, n, t, tan, col, tri = self._primitive(prim, node["mesh"], rules[material])
                    wp = (p @ m[:3, :3].T + m[:3, 3]).astype(np.float32)
                    if not np.isfinite(wp).all():
                        raise UserError(f"{self.path.name}: non-finite vertex positions in mesh {node['mesh']} "
                                        f"(node {node_index})")
                    wn = compute_normals(wp, tri) if n is None else n @ _normal_matrix(m[:3, :3])
                    if mats[material].normal_map is None:
                        tan = None
                    elif tan is None:
                        tan = generate_tangents(wp, wn, t, tri)
                    else:  # the file's: xyz moves with the mesh, w keeps the uv handedness
                        xyz = tan[:, :3] @ m[:3, :3].T
                        sign = -1.0 if np.linalg.det(m[:3, :3]) < 0 else 1.0
                        tan = np.concatenate([xyz, tan[:, 3:4] * sign], 1).astype(np.float32)
                    if np.linalg.det(m[:3, :3]) < 0:
                        tri = tri[:, [0, 2, 1]]
                    pos.append(wp)
                    nrm.append(wn)
                    uvs.append(t)
                    tangents.append(tan if tan is not None else np.zeros((p.shape[0], 4), np.float32))
                    colors.append(col)
                    idx.append(tri + count)
                    mid.append(np.full(tri.shape[0], material, np.int32))
                    count += p.shape[0]
            ext = node.get("extensions", {}).get("KHR_lights_punctual")
            if ext is not None:
                lights.append(self._light(light_defs[ext["light"]], m))
            if "camera" in node:
                self._camera(doc["cameras"][node["camera"]], node, m, views)
            for child in reversed(node.get("children", [])):
                todo.append((child, m))
        if not pos:
            raise UserError(f"{self.path.name}: the file has no triangle meshes")
        scene = Scene(self.path.stem, np.concatenate(pos), np.concatenate(nrm), np.concatenate(uvs),
                      np.concatenate(idx), np.concatenate(mid), mats, lights, Environment("black"), views,
                      str(self.path), brdf="ggx")
        if any(mat.normal_map is not None for mat in mats):
            scene.tangents = np.concatenate(tangents)
        if any(c is not None for c in colors):  # white where a primitive has none
            scene.colors = np.concatenate([c if c is not None else np.ones((len(p_), 3), np.float32)
                                           for c, p_ in zip(colors, pos, strict=True)])
        scene.validate()
        return scene

    def _primitive(self, prim: dict, mesh: int, rule: UvRule):
        """Positions, normals (or None), uvs (the material's set, transformed), tangents (or
        None), vertex colours (or None) and triangles of a triangle primitive."""
        attrs = prim["attributes"]
        p = self.accessor(attrs["POSITION"]).astype(np.float32)
        if not np.isfinite(p).all():
            raise UserError(f"{self.path.name}: non-finite vertex positions in mesh {mesh}")
        if "indices" in prim:
            tri = self.accessor(prim["indices"]).astype(np.int64).ravel()
        else:
            tri = np.arange(p.shape[0], dtype=np.int64)
        if tri.size % 3:
            raise UserError(f"{self.path.name}: mesh {mesh}: {tri.size} indices is not a whole number of triangles")
        tri = tri.reshape(-1, 3)
        if tri.size and tri.max() >= p.shape[0]:
            raise UserError(f"{self.path.name}: triangle indices out of range in mesh {mesh}")
        n = self.accessor(attrs["NORMAL"]).astype(np.float32) if "NORMAL" in attrs else None
        uv_name = f"TEXCOORD_{rule.texcoord}"
        if uv_name in attrs:
            t = rule.apply(self.accessor(attrs[uv_name]).astype(np.float32))
        else:
            if rule.texcoord and "uv" not in self._warned:
                self._warned.add("uv")
                warnings.warn(f"{self.path.name}: mesh {mesh} has no {uv_name} for its material's textures",
                              stacklevel=3)
            t = np.zeros((p.shape[0], 2), np.float32)
        t = np.where(np.isfinite(t), t, 0.0).astype(np.float32)
        tan = self.accessor(attrs["TANGENT"]).astype(np.float32) if "TANGENT" in attrs else None
        if tan is not None and not np.isfinite(tan).all():
            tan = None  # generated instead
        col = None
        if "COLOR_0" in attrs:  # linear RGB(A), normalised integers or floats; alpha is not used
            col = self.accessor(attrs["COLOR_0"]).astype(np.float32)[:, :3]
        return p, n, t, tan, col, tri

    def _camera(self, cam: dict, node: dict, m: np.ndarray, views: dict) -> None:
        name = cam.get("name") or node.get("name") or f"camera_{len(views)}"
        if cam["type"] != "perspective":
            warnings.warn(f"{self.path.name}: camera {str(name)[:60]!r} is orthographic; rtlab's cameras are "
                          "perspective, so it is not offered as a view", stacklevel=2)
            return
        fwd, up = -m[:3, 2], m[:3, 1]
        lf, lu = np.linalg.norm(fwd), np.linalg.norm(up)
        if not (lf > 1e-12 and lu > 1e-12 and np.linalg.norm(np.cross(fwd / lf, up / lu)) > 1e-6):
            warnings.warn(f"{self.path.name}: camera {str(name)[:60]!r} has a degenerate transform; skipped",
                          stacklevel=2)
            return
        eye = m[:3, 3]
        views[str(name)] = View(str(name), tuple(map(float, eye)), tuple(map(float, eye + fwd / lf)),
                                tuple(map(float, up / lu)), float(np.degrees(cam["perspective"]["yfov"])))

    def _light(self, d: dict, m: np.ndarray) -> Light:
        kind = d.get("type")
        color = tuple(float(c) for c in d.get("color", (1, 1, 1)))
        intensity = float(d.get("intensity", 1.0))
        axis = -m[:3, 2]
        length = np.linalg.norm(axis)
        axis = axis / length if length > 1e-30 else np.array([0.0, -1.0, 0.0])
        if not np.isfinite(np.float32(max(color)) * np.float32(intensity)):
            raise UserError(f"{self.path.name}: light {str(d.get('name', ''))[:60]!r}: color x intensity "
                            "overflows float32")
        common = dict(color=color, intensity=intensity, position=tuple(map(float, m[:3, 3])),
                      direction=tuple(map(float, axis)), name=d.get("name", ""))
        if kind == "spot":
            spot = d.get("spot", {})
            return Light(kind="spot", inner_cone=float(spot.get("innerConeAngle", 0.0)),
                         outer_cone=float(spot.get("outerConeAngle", np.pi / 4)), **common)
        return Light(kind=kind, **common)
