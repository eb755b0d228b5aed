"""Wavefront OBJ (+MTL) reader.

Read by rtlab itself rather than a general-purpose library so that every value is checked
(finite float32 coordinates, indices within their arrays, MTL numbers in range) and every
file the OBJ names (mtllib, map_Kd) goes through safe_child and open_regular at the moment it
is opened: no spelling of a reference can read outside the scene's folder. Polygons are fanned
into triangles; `v`'s optional colours, groups, smoothing groups, lines and points are ignored.
"""
from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

from core.errors import UserError
from scenes.loaders.checks import F32_MAX, read_regular
from scenes.loaders.common import check_memory, compute_normals, decode_image, safe_child, srgb_to_linear
from scenes.model import Environment, Material, Scene

MAX_MTL_BYTES = 64 << 20


def _text(data: bytes) -> list[list[str]]:
    """The file's lines as whitespace-split words (any Unicode space, CR, form feed, NUL...).
    Undecodable bytes are kept as latin-1: OBJ's words are ASCII, names may not be."""
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError:
        text = data.decode("latin-1")
    out = []
    for line in text.replace("\0", " ").splitlines():
        words = line.split()
        if words and not words[0].startswith("#"):
            out.append(words)
    return out


def _floats(rows: list[list[str]], width: int, what: str, name: str, lo: int) -> np.ndarray:
    """rows of number words -> (n, width) float32; rows need at least `lo` numbers, missing
    ones are 0; every value must be a finite float32."""
    arr = np.zeros((len(rows), width), np.float32)
    for k, row in enumerate(rows):
        if len(row) < lo:
            raise UserError(f"{name}: {what} {k + 1} has {len(row)} number(s), needs {lo}")
        try:
            vals = [float(x) for x in row[:width]]
        except ValueError:
            raise UserError(f"{name}: {what} {k + 1}: {' '.join(row[:width])[:60]!r} is not a list of numbers") \
                from None
        if not all(abs(v) <= F32_MAX for v in vals):  # NaN fails too
            raise UserError(f"{name}: {what} {k + 1}: values must be finite float32 numbers")
        arr[k, :len(vals)] = vals
    return arr


class _Obj:
    def __init__(self, path: Path):
        self.path, self.name = path, path.name
        self.v, self.vt, self.vn = [], [], []
        self.corners: list[tuple[int, int, int]] = []  # (v, vt, vn) per triangle corner, 1-based resolved
        self.tri_mat: list[int] = []
        self.materials: dict[str, Material] = {}
        self.order: dict[str, int] = {}  # material name -> its index, in order of first use

    def parse(self) -> None:
        current = self._material("default")
        for words in _text(read_regular(self.path, self.name)):
            key = words[0]
            if key == "v":
                self.v.append(words[1:4])
            elif key == "vt":
                self.vt.append(words[1:3])
            elif key == "vn":
                self.vn.append(words[1:4])
            elif key == "f":
                self._face(words[1:], current)
            elif key == "usemtl":
                current = self._material(" ".join(words[1:]) or "default")
            elif key == "mtllib":
                self._mtllib(words[1:])

    def _material(self, name: str) -> int:
        if name not in self.materials:
            self.materials[name] = Material(name, (0.8, 0.8, 0.8, 1.0), None, 0.8, 0.0, (0.0, 0.0, 0.0), True)
        return self.order.setdefault(name, len(self.order))

    def _face(self, refs: list[str], mat: int) -> None:
        if len(refs) < 3:
            return  # a degenerate face: no surface
        counts = (len(self.v), len(self.vt), len(self.vn))
        corners = []
        for ref in refs:
            parts = ref.split("/")
            if len(parts) > 3:
                raise UserError(f"{self.name}: face vertex {ref[:40]!r} has more than three indices")
            ids = []
            for k, part in enumerate(parts):
                if k > 0 and part == "":
                    ids.append(0)
                    continue
                try:
                    i = int(part)
                except ValueError:
                    raise UserError(f"{self.name}: face vertex {ref[:40]!r} is not v, v/vt, v//vn or v/vt/vn") \
                        from None
                if i < 0:
                    i = counts[k] + 1 + i  # relative to the end of what is defined so far
                if not 1 <= i <= counts[k]:
                    what = ("vertex", "texture coordinate", "normal")[k]
                    raise UserError(f"{self.name}: face refers to {what} {part[:30]}, but only {counts[k]} are "
                                    "defined before it")
                ids.append(i)
            ids += [0] * (3 - len(ids))
            corners.append(tuple(ids))
        for j in range(1, len(corners) - 1):  # a fan: convex polygons, as OBJ writers emit them
            self.corners += (corners[0], corners[j], corners[j + 1])
            self.tri_mat.append(mat)

    def _mtllib(self, words: list[str]) -> None:
        names = [" ".join(words)] if words else []
        if not words:
            return
        if not safe_child(self.path, names[0]).is_file():
            names = words  # several libraries, separated by spaces
        for name in names:
            target = safe_child(self.path, name)
            if not target.exists():
                warnings.warn(f"{self.name}: material library {name[:80]!r} not found; its materials render grey",
                              stacklevel=3)
                continue
            self._mtl(target)

    def _mtl(self, path: Path) -> None:
        mat = None
        for words in _text(read_regular(path, self.name, MAX_MTL_BYTES)):
            key = words[0].lower()
            if key == "newmtl":
                name = " ".join(words[1:]) or "default"
                self.materials[name] = mat = Material(name, (0.8, 0.8, 0.8, 1.0), None, 0.8, 0.0, (0, 0, 0), True)
                continue
            if mat is None:
                continue
            if key in ("kd", "ke", "ns", "d", "tr", "pr", "pm"):
                what = f"{words[0]} of material {mat.name[:40]!r}"
                vals = _floats([words[1:]], 3 if key in ("kd", "ke") else 1, what, path.name, 1)[0].astype(float)
                if key == "kd":
                    vals = vals if len(words) >= 4 else np.full(3, vals[0])
                    mat.base_color = tuple(srgb_to_linear(np.clip(vals, 0, 1)).tolist()) + (mat.base_color[3],)
                elif key == "ke":
                    vals = vals if len(words) >= 4 else np.full(3, vals[0])
                    mat.emissive = tuple(float(x) for x in np.clip(vals, 0, F32_MAX))
                elif key == "ns":  # Phong exponent -> roughness, as trimesh's to_pbr maps it
                    mat.roughness = float((2.0 / (np.clip(vals[0], 0.0, 1e6) + 2.0)) ** 0.25)
                elif key == "pr":
                    mat.roughness = float(np.clip(vals[0], 0, 1))
                elif key == "pm":
                    mat.metallic = float(np.clip(vals[0], 0, 1))
            elif key == "map_kd" and len(words) > 1:
                mat.texture = self._texture(words[-1], path)

    def _texture(self, name: str, mtl: Path) -> np.ndarray | None:
        target = safe_child(mtl, name)  # relative to the MTL, which lies in the OBJ's folder
        what = f"{self.name}: texture {name[:80]!r}"
        try:
            data = read_regular(target, self.name)
        except UserError as e:
            warnings.warn(f"{what}: {str(e).split(': ', 1)[-1]}; the material renders without it", stacklevel=4)
            return None
        return decode_image(data, what)

    def scene(self) -> Scene:
        if not self.corners:
            raise UserError(f"{self.name}: the file has no triangles")
        check_memory(len(self.tri_mat), len(self.corners), self.name)
        v = _floats(self.v, 3, "vertex", self.name, 3)
        vt = _floats(self.vt, 2, "texture coordinate", self.name, 1)
        vn = _floats(self.vn, 3, "normal", self.name, 3)
        # one vertex per distinct (v, vt, vn) triple, as the GPU wants them
        corners = np.asarray(self.corners, np.int64)
        unique, tri = np.unique(corners, axis=0, return_inverse=True)
        tri = tri.reshape(-1, 3).astype(np.int64)
        pos = v[unique[:, 0] - 1]
        uv = np.zeros((len(unique), 2), np.float32)
        has_uv = unique[:, 1] > 0
        uv[has_uv] = vt[unique[has_uv, 1] - 1]
        uv[:, 1] = 1.0 - uv[:, 1]  # OBJ's v points up; the model's (glTF's) points down
        has_n = unique[:, 2] > 0
        nrm = compute_normals(pos, tri)
        nrm[has_n] = vn[unique[has_n, 2] - 1]
        names = list(self.order)
        used, tri_mat = np.unique(np.asarray(self.tri_mat, np.int64), return_inverse=True)
        mats = [self.materials[names[k]] for k in used]  # only the materials that faces use
        scene = Scene(self.path.stem, pos, nrm, uv, tri, tri_mat.astype(np.int32), mats, [],
                      Environment("black"), {}, str(self.path))
        scene.validate()
        return scene


def load_obj(path: Path) -> Scene:
    size = path.stat().st_size  # as many triangles and vertices as ~13 and ~12 bytes of text make
    check_memory(size // 13, size // 12, path.name)
    obj = _Obj(path)
    obj.parse()
    with np.errstate(all="ignore"):
        return obj.scene()
