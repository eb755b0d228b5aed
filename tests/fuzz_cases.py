"""Hostile and malformed scene files for the fuzz tests (test helper, not part of rtlab).

Hypothesis strategies mutate valid glTF, GLB, OBJ/MTL and PLY scenes (values of the wrong
type, shape or size, numbers past float32 and int32, huge declared counts, references outside
the folder, truncation, flipped bytes), and `check_load` loads each in a forked child under a
memory limit and a time limit, reporting anything but a Scene or one clean UserError line.
"""
from __future__ import annotations

import copy
import json
import os
import resource
import signal
import struct
import traceback
import warnings
from pathlib import Path

import numpy as np
from hypothesis import strategies as st

from tests.gltf_writer import png_bytes, quad_document

CASE_SECONDS = 30
CASE_MEMORY = 2 << 30  # address space each case may add to what the test process already has


class Raw:
    """JSON text put into a document as is (numbers and nesting json.dumps cannot write)."""

    def __init__(self, text: str):
        self.text = text


def dumps(doc) -> bytes:
    raws = []

    def default(o):
        raws.append(o.text)
        return f"@@RAW{len(raws) - 1}@@"

    text = json.dumps(doc, default=default)
    for k, raw in enumerate(raws):
        text = text.replace(f'"@@RAW{k}@@"', raw, 1)
    return text.encode()


HOSTILE_NUMBERS = [0, -1, 1, 2, 3, 4, 5, 255, 256, 65535, 2**31 - 1, 2**31, 2**32, 2**53, 2**63, -2**63, 10**30,
                   0.5, -0.0, 1e-45, 1e38, 3.5e38, 1e308, -1e308, Raw("1e400"), Raw("-1e400"), Raw("NaN"),
                   Raw("Infinity"), Raw("9" * 401), Raw("9" * 5000)]
HOSTILE_STRINGS = ["", "x", "../../../../etc/passwd", "/etc/passwd", "..", "data:,x", "data:;base64,@@@",
                   "a" * 300, "dir/" * 100 + "f.png", "n\0ul.png", "fifo.png", "%2e%2e/%2e%2e/x.bin",
                   "KHR_draco_mesh_compression",
                   "MASK", "perspective", "orthographic", "spot", "VEC3", "SCALAR", "MAT4"]


def hostile_values():
    leaf = st.one_of(st.none(), st.booleans(), st.sampled_from(HOSTILE_NUMBERS), st.sampled_from(HOSTILE_STRINGS),
                     st.integers(-2**70, 2**70), st.floats(allow_nan=False, allow_infinity=False, width=64))
    small_lists = st.lists(st.one_of(st.sampled_from(HOSTILE_NUMBERS), st.floats(-10, 10)), max_size=6)
    return st.one_of(leaf, small_lists, st.just([]), st.just({}), st.just([[1, 2, 3]]), st.just({"index": 0}),
                     st.just(Raw("[" * 100_000 + "]" * 100_000)), st.just(Raw("[" * 100 + "0" + "]" * 100)))


def _paths(node, prefix=()):
    """Every (container, key) in a JSON tree, with its path."""
    out = []
    if isinstance(node, dict):
        items = node.items()
    elif isinstance(node, list):
        items = enumerate(node)
    else:
        return out
    for k, v in items:
        out.append((prefix + (k,), node, k))
        out += _paths(v, prefix + (k,))
    return out


BASE_DOCS = ("data", "external", "glb", "textured", "chain")


def base_document(kind: str):
    """(doc, binary blob, extra files) of a valid scene."""
    if kind == "textured":
        doc, blob = quad_document("data", image_uri="tex.png")
        return doc, blob, {"tex.png": png_bytes(np.full((4, 4, 3), 200, np.uint8))}
    if kind == "external":
        doc, blob = quad_document("quad.bin")
        return doc, blob, {"quad.bin": blob}
    doc, blob = quad_document("data" if kind != "glb" else None)
    if kind == "chain":  # a hierarchy: node 0's mesh under a chain of parents
        doc["nodes"] += [{"children": [0], "scale": [2, 2, 2]}, {"children": [5], "rotation": [0, 0.7071068, 0,
                                                                                                0.7071068]}]
        doc["scenes"][0]["nodes"] = [6, 1, 2, 3, 4]
    return doc, blob, {}


@st.composite
def gltf_cases(draw):
    """(file name, bytes, extra files) of a mutated glTF or GLB scene."""
    kind = draw(st.sampled_from(BASE_DOCS))
    doc, blob, extra = base_document(kind)
    doc = copy.deepcopy(doc)
    if draw(st.integers(0, 9)) == 0:  # a node DAG: every node lists the next one twice
        n = len(doc["nodes"])
        doc["nodes"] += [{"children": [n + k + 1, n + k + 1]} for k in range(30)] + [{"mesh": 0}]
        doc["scenes"][0]["nodes"] = [n]
    for _ in range(draw(st.integers(0 if len(doc["nodes"]) > 10 else 1, 3))):
        paths = _paths(doc)
        path, parent, key = draw(st.sampled_from(paths))
        op = draw(st.sampled_from(["replace", "replace", "replace", "delete", "duplicate", "grow"]))
        if op == "delete":
            if isinstance(parent, dict):
                del parent[key]
            else:
                parent.pop(key)
        elif op == "duplicate" and isinstance(parent, list):
            parent.append(copy.deepcopy(parent[key]))
        elif op == "grow" and isinstance(parent[key], (int, float)) and not isinstance(parent[key], bool):
            parent[key] = draw(st.sampled_from([2**31 - 1, 10**9, 10**7, 4_000_000_000, 2**63 - 1]))
        else:
            parent[key] = draw(hostile_values())
    text = dumps(doc)
    if kind == "glb":
        text += b" " * (-len(text) % 4)
        body = struct.pack("<II", len(text), 0x4E4F534A) + text + struct.pack("<II", len(blob), 0x004E4942) + blob
        data = struct.pack("<III", 0x46546C67, 2, 12 + len(body)) + body
        data = _byte_mutations(draw, data)
        return "scene.glb", data, extra
    return "scene.gltf", text, extra


def _byte_mutations(draw, data: bytes) -> bytes:
    data = bytearray(data)
    for _ in range(draw(st.integers(0, 3))):
        op = draw(st.sampled_from(["flip", "truncate", "u32"]))
        if not data:
            break
        at = draw(st.integers(0, len(data) - 1))
        if op == "flip":
            data[at] ^= draw(st.integers(1, 255))
        elif op == "truncate":
            data = data[:at]
        elif at + 4 <= len(data):
            data[at:at + 4] = struct.pack("<I", draw(st.sampled_from([0, 1, 0x7FFFFFFF, 0xFFFFFFFF, 0x10000000])))
    return bytes(data)


OBJ_BASE = ("mtllib scene.mtl\nv -1 0 -1\nv 1 0 -1\nv 1 0 1\nv -1 0 1\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n"
            "vn 0 1 0\nusemtl red\nf 1/1/1 3/3/1 2/2/1\nf 1/1/1 4/4/1 3/3/1\nusemtl glow\n"
            "f -4/-4/-1 -2/-2/-1 -3/-3/-1\n")
MTL_BASE = "newmtl red\nKd 0.8 0.1 0.1\nNs 50\nmap_Kd tex.png\nnewmtl glow\nKd 1 1 1\nKe 2 2 2\n"
OBJ_TOKENS = ["v", "vt", "vn", "f", "usemtl", "mtllib", "map_Kd", "MAP_KD", "Ns", "Kd", "Ke", "d", "Pr", "Pm", "1",
              "-1", "0", "1e308", "-1e308", "1e400", "nan", "inf", "-2", "2147483648", "99999999999999999999",
              "1/1/1", "1//1", "/", "//", "1/2/3/4", "../../etc/passwd", "/etc/passwd", "\0", "\u00a0", "\u2028",
              "\x0c", "\r", "é", "\xff", "fifo.png", "x" * 300, "scene.mtl", "tex.png", "newmtl"]


@st.composite
def obj_cases(draw):
    """(file name, bytes, extra files) of a mutated OBJ with its MTL and texture."""
    files = {"scene.obj": OBJ_BASE, "scene.mtl": MTL_BASE}
    target = draw(st.sampled_from(["scene.obj", "scene.mtl"]))
    words = files[target].replace("\n", " \n ").split(" ")
    for _ in range(draw(st.integers(1, 4))):
        at = draw(st.integers(0, len(words) - 1))
        op = draw(st.sampled_from(["replace", "insert", "delete"]))
        token = draw(st.sampled_from(OBJ_TOKENS))
        if op == "replace":
            words[at] = token
        elif op == "insert":
            words.insert(at, token)
        elif len(words) > 1:
            words.pop(at)
    files[target] = " ".join(words)
    if draw(st.integers(0, 9)) == 0:  # one polygon of many vertices
        n = draw(st.sampled_from([1000, 200_000]))
        t = np.linspace(0, 2 * np.pi, n, endpoint=False)
        files["scene.obj"] = "".join(f"v {np.cos(a):.4f} 0 {np.sin(a):.4f}\n" for a in t) + \
            "f " + " ".join(str(k + 1) for k in range(n)) + "\n"
    encode = (lambda s: s.encode("latin-1", "replace")) if draw(st.booleans()) else (lambda s: s.encode())
    extra = {"scene.mtl": encode(files["scene.mtl"]), "tex.png": png_bytes(np.full((4, 4, 3), 90, np.uint8))}
    return "scene.obj", encode(files["scene.obj"]), extra


def ply_bytes(fmt: str = "ascii", vertex_count=4, face_count=2, extra_header: str = "") -> bytes:
    pos = np.array([[-1, 0, -1], [1, 0, -1], [1, 0, 1], [-1, 0, 1]], np.float32)
    faces = [[0, 2, 1], [0, 3, 2]]
    header = (f"ply\nformat {fmt} 1.0\n{extra_header}element vertex {vertex_count}\nproperty float x\n"
              f"property float y\nproperty float z\nproperty uchar red\nproperty uchar green\nproperty uchar blue\n"
              f"element face {face_count}\nproperty list uchar int vertex_indices\nend_header\n")
    if fmt == "ascii":
        body = "".join(f"{x} {y} {z} 200 100 50\n" for x, y, z in pos)
        body += "".join(f"3 {a} {b} {c}\n" for a, b, c in faces)
        return (header + body).encode()
    order = "<" if fmt == "binary_little_endian" else ">"
    body = b"".join(struct.pack(order + "fffBBB", *p, 200, 100, 50) for p in pos)
    body += b"".join(struct.pack(order + "Biii", 3, *f) for f in faces)
    return header.encode() + body


@st.composite
def ply_cases(draw):
    fmt = draw(st.sampled_from(["ascii", "binary_little_endian", "binary_big_endian"]))
    counts = st.sampled_from([0, 1, 3, 4, 5, 2**31 - 1, 2**32, 10**12, 10**30])
    v = draw(st.one_of(st.just(4), counts))
    f = draw(st.one_of(st.just(2), counts))
    extra = draw(st.sampled_from(["", "comment TextureFile tex.png\n", "comment TextureFile ../../etc/passwd\n",
                                  "comment TextureFile /etc/passwd\n", "comment TextureFile fifo.png\n",
                                  "element junk 3\nproperty list uint double stuff\n", "property float w\n"]))
    data = ply_bytes(fmt, v, f, extra)
    if draw(st.booleans()):
        data = _byte_mutations(draw, data)
    return "scene.ply", data, {"tex.png": png_bytes(np.full((4, 4, 3), 90, np.uint8))}


def random_bytes_cases():
    return st.tuples(st.sampled_from(["r.gltf", "r.glb", "r.obj", "r.ply"]), st.binary(max_size=600), st.just({}))


def scene_cases():
    return st.one_of(gltf_cases(), gltf_cases(), obj_cases(), ply_cases(), random_bytes_cases())


def write_case(folder: Path, name: str, data: bytes, extra: dict) -> Path:
    for fname, content in extra.items():
        (folder / fname).write_bytes(content)
    if not (folder / "fifo.png").exists():
        os.mkfifo(folder / "fifo.png")
    path = folder / name
    path.write_bytes(data)
    return path


def check_load(path: Path) -> tuple[str | None, str]:
    """Loads `path` in a forked child (memory and time limited). Returns (problem, outcome):
    problem None if the outcome was a valid scene or one clean error line, else what went
    wrong; outcome: "scene" or the error line, then " | warning: ..." for each warning."""
    read, write = os.pipe()
    pid = os.fork()
    if pid == 0:  # the child: load, report, exit without running the parent's cleanup
        os.close(read)
        try:
            soft = _address_space() + CASE_MEMORY
            resource.setrlimit(resource.RLIMIT_AS, (soft, soft))
            signal.alarm(CASE_SECONDS)
            report = _load_report(path)
        except BaseException as e:  # noqa: BLE001
            report = (f"harness: {type(e).__name__}: {e}", "?")
        os.write(write, json.dumps(report).encode()[:60000])
        os._exit(0)
    os.close(write)
    chunks = []
    while True:
        chunk = os.read(read, 65536)
        if not chunk:
            break
        chunks.append(chunk)
    os.close(read)
    _, status = os.waitpid(pid, 0)
    if os.WIFSIGNALED(status):
        sig = os.WTERMSIG(status)
        return ("hang (over the time limit)" if sig == signal.SIGALRM else f"killed by signal {sig}"), "killed"
    try:
        problem, outcome = json.loads(b"".join(chunks).decode())
    except ValueError:
        return "the child's report was cut off", "?"
    return problem, outcome


def _address_space() -> int:
    with open("/proc/self/statm") as f:
        return int(f.read().split()[0]) * os.sysconf("SC_PAGE_SIZE")


def _load_report(path: Path) -> tuple[str | None, str]:
    from core.errors import UserError
    from scenes.loaders import load_scene

    outcome = "scene"
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            scene = load_scene(str(path))
        except UserError as e:
            outcome = text = str(e)
            if "\n" in text or not text.strip() or len(text) > 600:
                return f"error message is not one short line: {text[:300]!r}", outcome
        except MemoryError:
            return "MemoryError (the memory limit per case was hit)", "?"
        except BaseException as e:  # noqa: BLE001
            return f"{type(e).__name__}: {e}\n{traceback.format_exc()[-3000:]}", "?"
        else:
            if not (np.isfinite(scene.positions).all() and np.isfinite(scene.normals).all()):
                return "the scene has non-finite positions or normals", outcome
    for w in caught:
        if w.category is not UserWarning or "\n" in str(w.message):
            return f"a {w.category.__name__} reached the user: {str(w.message)[:300]}", outcome
        outcome += f" | warning: {w.message}"
    return None, outcome
