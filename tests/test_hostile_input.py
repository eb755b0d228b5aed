"""Every kind of hostile input that the fuzzer of issue 30 found: each gives one clean error
line (or renders, with at most one-line warnings), never a traceback, hang or blow-up."""
import base64
import copy
import json
import os
import signal
import struct
import subprocess
import sys
import zlib

import numpy as np
import pytest

from tests.fuzz_cases import Raw, check_load, dumps, ply_bytes
from tests.gltf_writer import png_bytes, quad_document, write_gltf


def rtlab(*args, cwd=None, timeout=300):
    return subprocess.run([sys.executable, "-m", "app.cli", *args], capture_output=True, text=True, cwd=cwd,
                          timeout=timeout)


def loaded(outcome: str) -> bool:
    """check_load's outcome was a scene (with or without warnings), not an error."""
    return outcome == "scene" or outcome.startswith("scene | ")


def _doc(edit):
    doc, _ = quad_document("data")
    doc = copy.deepcopy(doc)
    edit(doc)
    return doc


def _set(path, value):
    def edit(doc):
        node = doc
        for key in path[:-1]:
            node = node[key]
        node[path[-1]] = value
    return edit


def _light(value):
    return _set(("extensions", "KHR_lights_punctual", "lights", 0, "color"), value)


def _base_color(value):
    return _set(("materials", 0, "pbrMetallicRoughness", "baseColorFactor"), value)


GLTF_CASES = {  # name: (edit of the quad document, expected text of the error or warning; "scene": loads)
    "light color of 1": (_light([1]), "color: expected 3 numbers, got 1"),
    "light color of 2": (_light([1, 1]), "color: expected 3 numbers, got 2"),
    "light color of 5": (_light([1, 1, 1, 1, 1]), "color: expected 3 numbers, got 5"),
    "baseColorFactor []": (_base_color([]), "baseColorFactor: expected 4 numbers, got 0"),
    "baseColorFactor [1]": (_base_color([1]), "baseColorFactor: expected 4 numbers, got 1"),
    "baseColorFactor [1,1]": (_base_color([1, 1]), "baseColorFactor: expected 4 numbers, got 2"),
    "emissiveFactor []": (_set(("materials", 0, "emissiveFactor"), []), "emissiveFactor: expected 3 numbers"),
    "emissiveFactor of 4": (_set(("materials", 0, "emissiveFactor"), [1, 1, 1, 1]), "expected 3 numbers, got 4"),
    "material 2**31": (_set(("meshes", 0, "primitives", 0, "material"), 2**31), "material: 2147483648 is out of"),
    "material 2**63": (_set(("meshes", 0, "primitives", 0, "material"), 2**63), "is out of range"),
    "count 1e400": (_set(("accessors", 0, "count"), Raw("1e400")), "count: expected an integer, got the number inf"),
    "count of 401 digits": (_set(("accessors", 0, "count"), Raw("9" * 401)), "an integer of 1333 bits is out of"),
    "count of 5000 digits": (_set(("accessors", 0, "count"), Raw("9" * 5000)), "malformed glTF JSON (Exceeds"),
    "nested 100000 deep": (_set(("asset",), Raw("[" * 100_000 + "]" * 100_000)), "nested too deeply"),
    "rotation 1e308": (_set(("nodes", 0, "rotation"), [1e308, 1e308, 0, 1]), "rotation[0]: 1e+308 is out of range"),
    "rotation 3e38": (_set(("nodes", 0, "rotation"), [3e38, 3e38, 0, 1]), "non-finite vertex positions"),
    "scale 1e38 x 1e38": (_set(("nodes", 0, "scale"), [3e38, 3e38, 3e38]), "the scene spans"),
    "normals without data, count 1e9": (_set(("accessors", 1), {"componentType": 5126, "count": 10**9, "type": "VEC3"}),
                                        "has 1000000000 entries, POSITION has 4"),
    "normals without data": (_set(("accessors", 1), {"componentType": 5126, "count": 4, "type": "VEC3"}),
                             "accessor 1 has no data (no bufferView)"),
    "required draco": (_set(("extensionsRequired",), ["KHR_draco_mesh_compression"]),
                       "requires KHR_draco_mesh_compression, which rtlab does not support"),
    "orthographic camera": (_set(("cameras", 0), {"type": "orthographic", "orthographic": {}}),
                            "orthographic; rtlab's cameras are perspective"),
    "camera yfov 0": (_set(("cameras", 0, "perspective", "yfov"), 0), "yfov: 0 is not within 0..pi"),
    "spot cones reversed": (_set(("extensions", "KHR_lights_punctual", "lights", 1, "spot"),
                                 {"innerConeAngle": 0.6, "outerConeAngle": 0.5}), "innerConeAngle < outerConeAngle"),
    "light intensity x color overflows": (_set(("extensions", "KHR_lights_punctual", "lights", 0),
                                                {"type": "point", "color": [3e38] * 3, "intensity": 10}), "overflows"),
}


def _dag(doc):
    n = len(doc["nodes"])
    doc["nodes"] += [{"children": [n + k + 1, n + k + 1]} for k in range(40)] + [{"mesh": 0}]
    doc["scenes"][0]["nodes"] = [n]


def _cycle(doc):
    doc["nodes"][0]["children"] = [5]
    doc["nodes"].append({"children": [0]})


GLTF_CASES["node DAG 2^40"] = (_dag, "has more than one parent")
GLTF_CASES["node cycle"] = (_cycle, "cycle")
GLTF_CASES["deep chain"] = (lambda d: d["nodes"].extend([{"children": [len(d["nodes"]) + k + 1]} for k in
                                                          range(5000)] + [{"mesh": 0}]) or
                            d["scenes"][0].update(nodes=[5]), "scene")


@pytest.mark.parametrize("name", list(GLTF_CASES))
def test_gltf_values_of_wrong_shape_or_size(tmp_path, name):
    edit, expected = GLTF_CASES[name]
    path = tmp_path / "scene.gltf"
    path.write_bytes(dumps(_doc(edit)))
    problem, outcome = check_load(path)
    assert problem is None, problem
    assert (loaded(outcome) if expected == "scene" else expected in outcome), outcome


def _png_header(width, height) -> bytes:
    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)) + \
        chunk(b"IDAT", zlib.compress(b"\0" * 64)) + chunk(b"IEND", b"")


def _gif_header(width, height) -> bytes:
    return b"GIF89a" + struct.pack("<HHBBB", width, height, 0, 0, 0) + b",\0\0\0\0" + \
        struct.pack("<HH", width, height) + b"\0\x02\x02D\x01\0;" + b"\0" * 30


def _dds_unknown_format() -> bytes:
    header = struct.pack("<IIIIIII", 124, 0x1007, 4, 4, 16, 0, 1) + b"\0" * 44
    pixel_format = struct.pack("<II4sIIIII", 32, 0x4, b"ZZZZ", 0, 0, 0, 0, 0)
    return b"DDS " + header + pixel_format + struct.pack("<IIIII", 0x1000, 0, 0, 0, 0) + b"\0" * 64


@pytest.mark.parametrize("name,image,expected", [
    ("GIF declaring 65149x2247", _gif_header(65149, 2247), "larger than rtlab decodes"),
    ("PNG declaring 13000x13000", _png_header(13000, 13000), "larger than rtlab decodes"),
    ("DDS of an unknown pixel format", _dds_unknown_format(), "cannot decode image"),
    ("random bytes", bytes(range(256)) * 3, "cannot decode image"),
])
def test_undecodable_or_huge_images_warn_and_render(tmp_path, name, image, expected):
    doc, _ = quad_document("data", image=image)
    problem, outcome = check_load(write_gltf(tmp_path / "scene.gltf", doc))
    assert problem is None, problem
    assert loaded(outcome) and expected in outcome, outcome


def test_fifo_and_missing_textures_warn_and_render(tmp_path):
    os.mkfifo(tmp_path / "fifo.png")
    for uri, expected in (("fifo.png", "is not a regular file"), ("missing.png", "No such file")):
        doc, _ = quad_document("data", image_uri=uri)
        problem, outcome = check_load(write_gltf(tmp_path / "scene.gltf", doc))
        assert problem is None, problem
        assert loaded(outcome) and expected in outcome and "renders without it" in outcome, outcome


def test_fifo_as_the_buffer_is_an_error(tmp_path):
    os.mkfifo(tmp_path / "quad.bin")
    doc, _ = quad_document("quad.bin")
    problem, outcome = check_load(write_gltf(tmp_path / "scene.gltf", doc))
    assert problem is None and "is not a regular file" in outcome, (problem, outcome)


OBJ = "v -1 0 -1\nv 1 0 -1\nv 0 0 1\n"


@pytest.mark.parametrize("name,obj,mtl,expected", [
    ("vertex of one coordinate", "v 1\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", None, "vertex 1 has 1 number(s), needs 3"),
    ("embedded NUL", OBJ + "f 1 2\0 3\n", None, "scene"),
    ("NUL in mtllib", "mtllib a\0b.mtl\n" + OBJ + "f 1 2 3\n", None, "scene"),
    ("Ns -2", "mtllib m.mtl\n" + OBJ + "usemtl a\nf 1 2 3\n", "newmtl a\nNs -2\n", "scene"),
    ("Ns -1e308", "mtllib m.mtl\n" + OBJ + "usemtl a\nf 1 2 3\n", "newmtl a\nNs -1e308\n", "finite float32"),
    ("vertex 1e308", "v 1e308 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", None, "finite float32"),
    ("vertex nan", "v nan 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", None, "finite float32"),
    ("index past the vertices", OBJ + "f 1 2 4\n", None, "face refers to vertex 4, but only 3"),
    ("index of 2**63", OBJ + "f 1 2 9223372036854775808\n", None, "face refers to vertex"),
    ("non-UTF-8 names", OBJ.replace("v -1", "o caf\xe9\nv -1") + "usemtl \xff\xfe\nf 1 2 3\n", None, "scene"),
    ("long file name in mtllib", "mtllib " + "m" * 300 + ".mtl\n" + OBJ + "f 1 2 3\n", None, "file name too long"),
    ("FIFO as the MTL", "mtllib fifo.mtl\n" + OBJ + "f 1 2 3\n", None, "is not a regular file"),
])
def test_obj_and_mtl_values(tmp_path, name, obj, mtl, expected):
    os.mkfifo(tmp_path / "fifo.mtl")
    (tmp_path / "scene.obj").write_bytes(obj.encode("latin-1"))
    if mtl is not None:
        (tmp_path / "m.mtl").write_text(mtl)
    problem, outcome = check_load(tmp_path / "scene.obj")
    assert problem is None, problem
    assert (loaded(outcome) if expected == "scene" else expected in outcome), outcome


def test_one_polygon_of_200000_vertices_loads(tmp_path):
    t = np.linspace(0, 2 * np.pi, 200_000, endpoint=False)
    text = "".join(f"v {np.cos(a):.5f} 0 {np.sin(a):.5f}\n" for a in t) + "f " + " ".join(map(str, range(1, 200_001)))
    (tmp_path / "disc.obj").write_text(text + "\n")
    problem, outcome = check_load(tmp_path / "disc.obj")
    assert problem is None and loaded(outcome), (problem, outcome)


def test_ply_grid_without_normals_loads(tmp_path):
    n = 300
    y, x = np.mgrid[0:n, 0:n]
    verts = np.stack([x.ravel(), np.zeros(n * n), y.ravel()], 1).astype(np.float32)
    q = (y[:-1, :-1] * n + x[:-1, :-1]).ravel()
    faces = np.stack([q, q + n, q + n + 1, q + 1], 1)
    header = (f"ply\nformat binary_little_endian 1.0\nelement vertex {n * n}\nproperty float x\nproperty float y\n"
              f"property float z\nelement face {len(faces)}\nproperty list uchar int vertex_indices\nend_header\n")
    rows = np.zeros(len(faces), [("n", "u1"), ("v", "<i4", (4,))])
    rows["n"], rows["v"] = 4, faces
    (tmp_path / "grid.ply").write_bytes(header.encode() + verts.tobytes() + rows.tobytes())
    problem, outcome = check_load(tmp_path / "grid.ply")
    assert problem is None and loaded(outcome), (problem, outcome)


@pytest.mark.parametrize("fmt", ["ascii", "binary_little_endian"])
@pytest.mark.parametrize("count", [10**6, 2**31 - 1, 10**12])
def test_ply_counts_larger_than_the_file_are_refused_before_allocating(tmp_path, fmt, count):
    (tmp_path / "big.ply").write_bytes(ply_bytes(fmt, vertex_count=count))
    problem, outcome = check_load(tmp_path / "big.ply")
    assert problem is None, problem
    assert "the file holds fewer" in outcome or "too large" in outcome or "bad PLY element" in outcome, outcome


OUTSIDE_COLOUR = (255, 0, 255)


@pytest.mark.parametrize("name,obj,mtl", [
    ("MAP_KD upper case", "mtllib m.mtl\n", "newmtl a\nMAP_KD ../outside.png\n"),
    ("CR before map_Kd", "mtllib m.mtl\n", "newmtl a\r\x0cmap_Kd ../outside.png\n"),
    ("U+2028 before map_Kd", "mtllib m.mtl\n", "newmtl a\u2028map_Kd ../outside.png\n"),
    ("NBSP separator", "mtllib m.mtl\n", "newmtl a\nmap_Kd\u00a0../outside.png\n"),
    ("absolute path", "mtllib m.mtl\n", "newmtl a\nmap_Kd /tmp/outside.png\n"),
    ("mtllib glued", "mtllib../outside.mtl\n", "newmtl a\n"),
    ("mtllib outside", "mtllib ../outside.mtl\n", "newmtl a\n"),
    ("link leaving the folder", "mtllib m.mtl\n", "newmtl a\nmap_Kd link.png\n"),
])
def test_references_never_read_outside_the_folder(tmp_path, name, obj, mtl):
    scene_dir = tmp_path / "scene"
    scene_dir.mkdir()
    (tmp_path / "outside.png").write_bytes(png_bytes(np.full((4, 4, 3), OUTSIDE_COLOUR, np.uint8)))
    (tmp_path / "outside.mtl").write_text("newmtl a\nKd 1 0 1\n")
    (scene_dir / "link.png").symlink_to(tmp_path / "outside.png")
    (scene_dir / "scene.obj").write_text(obj + "vt 0 0\n" + OBJ + "usemtl a\nf 1/1 2/1 3/1\n")
    (scene_dir / "m.mtl").write_text(mtl)
    problem, outcome = check_load(scene_dir / "scene.obj")
    assert problem is None, problem
    if loaded(outcome):
        from scenes.loaders import load_scene

        with pytest.warns(UserWarning):
            scene = load_scene(str(scene_dir / "scene.obj"))
        assert all(m.texture is None for m in scene.materials), name
        assert all(m.base_color[:3] != (1.0, 0.0, 1.0) for m in scene.materials), name
    else:
        assert "outside the scene's folder" in outcome or "must lie in the scene's folder" in outcome, outcome


@pytest.mark.parametrize("texture", ["../outside.png", "/tmp/x.png", "link.png"])
def test_ply_texture_file_stays_in_the_folder(tmp_path, texture):
    scene_dir = tmp_path / "scene"
    scene_dir.mkdir()
    (tmp_path / "outside.png").write_bytes(png_bytes(np.full((4, 4, 3), OUTSIDE_COLOUR, np.uint8)))
    (scene_dir / "link.png").symlink_to(tmp_path / "outside.png")
    (scene_dir / "t.ply").write_bytes(ply_bytes(extra_header=f"comment TextureFile {texture}\n"))
    problem, outcome = check_load(scene_dir / "t.ply")
    assert problem is None, problem
    assert "outside the scene's folder" in outcome or "must lie in the scene's folder" in outcome, outcome


def test_long_scene_path_is_one_line(tmp_path):
    r = rtlab("shot", str(tmp_path / ("a" * 300 + ".obj")), "--size", "16x16", "--out", str(tmp_path / "x.png"))
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and "rtlab: error:" in r.stderr, r.stderr
    assert not (tmp_path / "x.png").exists()


@pytest.mark.parametrize("args,needle", [
    (["--raw", "{tmp}/nodir/raw.npy"], "does not exist"),
    (["--raw", "{tmp}/raw.txt"], ".npy"),
    (["--raw", "{tmp}"], ".npy"),
    (["--raw", "{tmp}/adir.npy"], "it is a folder"),
    (["--out", "{tmp}/" + "o" * 300 + ".png"], "too long"),
    (["--size", "16384x16384"], "--size 16384x16384"),
    (["--frames", "1000000000000"], "--frames must be within"),
])
def test_outputs_and_options_are_checked_before_anything_is_written(tmp_path, args, needle):
    (tmp_path / "adir.npy").mkdir()
    args = [a.replace("{tmp}", str(tmp_path)) for a in args]
    out = tmp_path / "out.png"
    r = rtlab("shot", "arcade", "--pass", "ao", "--size", "16x16", "--out", str(out), *args)
    assert r.returncode == 2 and "Traceback" not in r.stderr, r.stderr
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and needle in lines[0], r.stderr
    assert not out.exists()


def test_a_very_long_run_announces_itself_and_ctrl_c_writes_nothing(tmp_path):
    out = tmp_path / "long.png"
    p = subprocess.Popen([sys.executable, "-m", "app.cli", "shot", "arcade", "--size", "16x16",
                          "--frames", "100000000", "--out", str(out)], stderr=subprocess.PIPE, text=True,
                         preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))  # a background job ignores it
    try:
        line = p.stderr.readline()
        p.send_signal(signal.SIGINT)
        rest = p.communicate(timeout=120)[1]
    finally:
        p.kill()
    assert "100,000,000 frames will take about" in line, line + rest
    assert p.returncode == 130 and "nothing written" in rest and "Traceback" not in rest, rest
    assert not out.exists()


def test_singular_camera_renders_or_fails_in_one_line(tmp_path):
    r = rtlab("shot", "arcade", "--pass", "ao", "--size", "16x16", "--camera", "eye=0,1e20,0;target=0,0,0",
              "--out", str(tmp_path / "c.png"))
    assert "Traceback" not in r.stderr and (r.returncode == 0 or r.stderr.count("\n") == 1), r.stderr


def test_internal_errors_are_one_line_unless_debug(monkeypatch, capsys):
    import app.cli

    def broken(args):
        raise RuntimeError("a bug")

    monkeypatch.setattr(app.cli, "cmd_scenes", broken)
    assert app.cli.main(["scenes"]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "internal error: RuntimeError: a bug (rerun with --debug" in err[0]
    with pytest.raises(RuntimeError):
        app.cli.main(["scenes", "--debug"])


def test_glb_with_data_uri_image_and_unicode(tmp_path):
    doc, _ = quad_document("data")
    doc["images"] = [{"uri": "data:image/png;base64," + base64.b64encode(png_bytes(np.zeros((2, 2, 3)))).decode()}]
    doc["textures"] = [{"source": 0}]
    doc["materials"][0]["name"] = "caf\u00e9 \u2028 \U0001f600"
    (tmp_path / "u.gltf").write_text(json.dumps(doc))
    problem, outcome = check_load(tmp_path / "u.gltf")
    assert problem is None and loaded(outcome), (problem, outcome)
