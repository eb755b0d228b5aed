"""Stanford PLY reader (ascii, binary little- and big-endian).

Read by rtlab itself so that the header's declared counts are checked against the bytes the
file holds before anything is allocated, every coordinate is a finite float32 and every index
lies within the vertex list. Vertex: x, y, z; optional nx, ny, nz; s, t (or u, v, texture_u,
texture_v); red, green, blue (their mean colours the mesh). Face: a list property
vertex_indices (or vertex_index), fanned into triangles. `comment TextureFile NAME` names a
base-colour texture in the scene's folder. Other elements and properties are skipped.
"""
from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

from core.errors import UserError
from scenes.loaders.checks import F32_MAX, MAX_ELEMENTS, read_regular
from scenes.loaders.common import check_memory, compute_normals, decode_image, safe_child, srgb_to_linear
from scenes.model import Environment, Material, Scene

TYPES = {"char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1", "short": "i2", "int16": "i2",
         "ushort": "u2", "uint16": "u2", "int": "i4", "int32": "i4", "uint": "u4", "uint32": "u4",
         "float": "f4", "float32": "f4", "double": "f8", "float64": "f8"}
FORMATS = {"ascii": None, "binary_little_endian": "<", "binary_big_endian": ">"}
MAX_HEADER = 1 << 16
UV_NAMES = (("s", "t"), ("u", "v"), ("texture_u", "texture_v"), ("texture_s", "texture_t"))


class _Element:
    def __init__(self, name: str, count: int):
        self.name, self.count = name, count
        self.props: list[tuple[str, str, str | None]] = []  # (name, value type, list count type or None)

    @property
    def has_list(self) -> bool:
        return any(p[2] is not None for p in self.props)


def _header(data: bytes, name: str):
    end = data.find(b"end_header", 0, MAX_HEADER)
    if not data.startswith(b"ply") or end < 0:
        raise UserError(f"{name}: not a PLY file (no 'ply' ... 'end_header' header)")
    body = data.find(b"\n", end) + 1
    if body == 0:
        raise UserError(f"{name}: truncated PLY (nothing after end_header)")
    fmt, elements, texture = None, [], None
    for line in data[:end].decode("latin-1").splitlines()[1:]:
        words = line.split()
        if not words:
            continue
        key = words[0]
        if key == "format":
            if len(words) < 2 or words[1] not in FORMATS:
                raise UserError(f"{name}: unknown PLY format {' '.join(words[1:])[:40]!r}")
            fmt = words[1]
        elif key == "comment" and len(words) > 2 and words[1].lower() == "texturefile":
            texture = line.split(None, 2)[2].strip()
        elif key == "element":
            if len(words) != 3 or not words[2].isdigit() or int(words[2]) > MAX_ELEMENTS:
                raise UserError(f"{name}: bad PLY element line {line[:60]!r}")
            elements.append(_Element(words[1], int(words[2])))
        elif key == "property":
            if not elements:
                raise UserError(f"{name}: PLY property before any element")
            if len(words) == 5 and words[1] == "list" and words[2] in TYPES and words[3] in TYPES:
                if TYPES[words[2]][0] == "f":
                    raise UserError(f"{name}: a PLY list count must be an integer type")
                elements[-1].props.append((words[4], TYPES[words[3]], TYPES[words[2]]))
            elif len(words) == 3 and words[1] in TYPES:
                elements[-1].props.append((words[2], TYPES[words[1]], None))
            else:
                raise UserError(f"{name}: bad PLY property line {line[:60]!r}")
    if fmt is None:
        raise UserError(f"{name}: PLY header has no format line")
    return fmt, elements, texture, body


def _read_ascii(tokens: np.ndarray, pos: int, el: _Element, name: str):
    """(columns by property name, next token) for one element of an ascii body."""
    width = len(el.props)
    if not el.has_list:
        need = el.count * width
        if pos + need > tokens.size:
            raise UserError(f"{name}: PLY element {el.name!r} declares {el.count:,} rows; the file holds fewer")
        rows = tokens[pos:pos + need].reshape(el.count, width)
        return {p[0]: rows[:, k] for k, p in enumerate(el.props)}, pos + need
    if el.count > (tokens.size - pos):
        raise UserError(f"{name}: PLY element {el.name!r} declares {el.count:,} rows; the file holds fewer")
    if len(el.props) == 1 and el.count:  # one list per row, as faces are: all of one length is fast
        n = tokens[pos]
        if n == int(n) and 0 <= n and pos + el.count * (1 + int(n)) <= tokens.size:
            rows = tokens[pos:pos + el.count * (1 + int(n))].reshape(el.count, 1 + int(n))
            if (rows[:, 0] == n).all():
                return {el.props[0][0]: rows[:, 1:]}, pos + rows.size
    cols = {p[0]: [] for p in el.props}
    for _ in range(el.count):
        for pname, _, counted in el.props:
            if pos >= tokens.size:
                raise UserError(f"{name}: PLY element {el.name!r} is truncated")
            if counted is None:
                cols[pname].append(tokens[pos])
                pos += 1
            else:
                n = tokens[pos]
                if not (0 <= n <= tokens.size - pos - 1 and n == int(n)):
                    raise UserError(f"{name}: PLY list of {n:g} entries in element {el.name!r}")
                cols[pname].append(tokens[pos + 1:pos + 1 + int(n)])
                pos += 1 + int(n)
    return {p[0]: (np.asarray(cols[p[0]]) if p[2] is None else cols[p[0]]) for p in el.props}, pos


def _read_binary(data: bytes, pos: int, el: _Element, order: str, name: str):
    """(columns by property name, next byte) for one element of a binary body."""
    if not el.has_list:
        dtype = np.dtype([(f"p{k}", order + p[1]) for k, p in enumerate(el.props)])
        need = el.count * dtype.itemsize
        if pos + need > len(data):
            raise UserError(f"{name}: PLY element {el.name!r} declares {el.count:,} rows; the file holds fewer")
        rows = np.frombuffer(data, dtype, el.count, pos)
        return {p[0]: rows[f"p{k}"] for k, p in enumerate(el.props)}, pos + need
    min_row = sum(np.dtype(p[2] or p[1]).itemsize for p in el.props)
    if el.count * min_row > len(data) - pos:
        raise UserError(f"{name}: PLY element {el.name!r} declares {el.count:,} rows; the file holds fewer")
    if len(el.props) == 1 and el.count:  # one list per row, as faces are: all of one length is fast
        ct, vt = np.dtype(order + el.props[0][2]), np.dtype(order + el.props[0][1])
        n = int(np.frombuffer(data, ct, 1, pos)[0]) if pos + ct.itemsize <= len(data) else -1
        fits = 0 <= n and pos + el.count * (ct.itemsize + n * vt.itemsize) <= len(data)
        row = np.dtype([("n", ct), ("v", vt, (n,))]) if fits else None
        if fits:
            rows = np.frombuffer(data, row, el.count, pos)
            if (rows["n"] == n).all():
                return {el.props[0][0]: rows["v"].reshape(el.count, n)}, pos + el.count * row.itemsize
    cols = {p[0]: [] for p in el.props}
    view = memoryview(data)
    for _ in range(el.count):
        for pname, vtype, counted in el.props:
            t = np.dtype(order + (counted or vtype))
            if pos + t.itemsize > len(data):
                raise UserError(f"{name}: PLY element {el.name!r} is truncated")
            value = np.frombuffer(view, t, 1, pos)[0]
            pos += t.itemsize
            if counted is None:
                cols[pname].append(value)
                continue
            vt = np.dtype(order + vtype)
            n = int(value)
            if n < 0 or pos + n * vt.itemsize > len(data):
                raise UserError(f"{name}: PLY list of {n} entries in element {el.name!r} runs past the file")
            cols[pname].append(np.frombuffer(view, vt, n, pos))
            pos += n * vt.itemsize
    return {p[0]: (np.asarray(cols[p[0]]) if p[2] is None else cols[p[0]]) for p in el.props}, pos


def _faces(lists, nverts: int, name: str) -> np.ndarray:
    """Polygons (a (F, n) array, or a list of index arrays) fanned into (T, 3) triangles, their
    indices checked."""
    if isinstance(lists, np.ndarray):
        groups = [lists]
    else:  # polygons of mixed sizes: one array per size
        by_size: dict[int, list] = {}
        for poly in lists:
            by_size.setdefault(len(poly), []).append(poly)
        groups = [np.asarray(polys) for polys in by_size.values()]
    tris = []
    for polys in groups:
        if polys.ndim != 2 or polys.shape[1] < 3 or polys.shape[0] == 0:
            continue
        bad = ~np.isfinite(polys) | (polys < 0) | (polys >= nverts) | (polys != np.floor(polys))
        if bad.any():
            raise UserError(f"{name}: face indices out of range (vertex count {nverts})")
        polys = polys.astype(np.int64)
        k = np.arange(1, polys.shape[1] - 1)
        fan = np.stack([np.broadcast_to(polys[:, :1], (polys.shape[0], k.size)), polys[:, k], polys[:, k + 1]], 2)
        tris.append(fan.reshape(-1, 3))
    return np.concatenate(tris) if tris else np.zeros((0, 3), np.int64)


def load_ply(path: Path) -> Scene:
    name = path.name
    data = read_regular(path, name)
    fmt, elements, texture, body = _header(data, name)
    verts = next((e for e in elements if e.name == "vertex"), None)
    faces = next((e for e in elements if e.name == "face"), None)
    if verts is None or faces is None:
        raise UserError(f"{name}: the file has no triangles (needs vertex and face elements)")
    check_memory(faces.count, verts.count, name)
    with np.errstate(all="ignore"):
        if fmt == "ascii":
            try:
                tokens = np.array(data[body:].split(), np.float64)
            except ValueError:
                raise UserError(f"{name}: the PLY body holds something that is not a number") from None
            pos, read = 0, (lambda el, p: _read_ascii(tokens, p, el, name))  # noqa: E731
        else:
            pos, read = body, (lambda el, p: _read_binary(data, p, el, FORMATS[fmt], name))  # noqa: E731
        columns = {}
        for el in elements:
            columns[el.name], pos = read(el, pos)
        return _scene(path, columns["vertex"], columns["face"], verts.count, texture)


def _scene(path: Path, v: dict, f: dict, count: int, texture: str | None) -> Scene:
    name = path.name
    if not all(k in v for k in "xyz"):
        raise UserError(f"{name}: PLY vertices need x, y and z")
    pos = np.stack([np.asarray(v[k], np.float64) for k in "xyz"], 1)
    if not (np.abs(pos) <= F32_MAX).all():
        raise UserError(f"{name}: vertex positions must be finite float32 numbers")
    lists = f.get("vertex_indices", f.get("vertex_index"))
    if not (isinstance(lists, list) or (isinstance(lists, np.ndarray) and lists.ndim == 2)):
        raise UserError(f"{name}: PLY faces need a list property vertex_indices")
    tri = _faces(lists, count, name)
    if tri.shape[0] == 0:
        raise UserError(f"{name}: the file has no triangles")
    pos = pos.astype(np.float32)
    nrm = compute_normals(pos, tri)
    if all(k in v for k in ("nx", "ny", "nz")):
        nrm = np.stack([np.asarray(v[k], np.float64) for k in ("nx", "ny", "nz")], 1)
        nrm = np.where(np.abs(nrm) <= F32_MAX, nrm, 0.0).astype(np.float32)
    uv = np.zeros((count, 2), np.float32)
    for a, b in UV_NAMES:
        if a in v and b in v:
            uv = np.stack([np.asarray(v[a], np.float64), 1.0 - np.asarray(v[b], np.float64)], 1)
            uv = np.where(np.isfinite(uv), uv, 0.0).astype(np.float32)
            break
    mat = Material("ply", (0.8, 0.8, 0.8, 1.0), None, 0.8, 0.0, (0.0, 0.0, 0.0), True)
    if all(k in v for k in ("red", "green", "blue")):
        rgb = np.stack([np.asarray(v[k], np.float64) for k in ("red", "green", "blue")], 1)
        rgb = rgb[np.isfinite(rgb).all(axis=1)]
        if rgb.size:
            c = np.clip(rgb.mean(axis=0) / (255.0 if rgb.max() > 1.0 else 1.0), 0, 1)
            mat.base_color = tuple(srgb_to_linear(c).tolist()) + (1.0,)
    if texture:
        target = safe_child(path, texture)
        try:
            mat.texture = decode_image(read_regular(target, name), f"{name}: texture {texture[:80]!r}")
        except UserError as e:
            warnings.warn(f"{name}: texture {texture[:80]!r}: {str(e).split(': ', 1)[-1]}; rendering without it",
                          stacklevel=3)
    scene = Scene(path.stem, pos, nrm, uv, tri, np.zeros(tri.shape[0], np.int32), [mat], [],
                  Environment("black"), {}, str(path))
    scene.validate()
    return scene
