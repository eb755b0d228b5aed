"""Bad input, odd scenes and interrupted writes: one clear line, no traceback, no NaN."""
import json
import subprocess
import sys

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from app.camera import Camera
from app.options import Options
from app.renderer import Renderer
from core.errors import UserError
from scenes.builder import SceneBuilder, box, grid, trs
from scenes.loaders import load_scene
from tests.gltf_writer import png_bytes, quad_document, write_glb, write_gltf


def rtlab(*args, cwd=None):
    return subprocess.run([sys.executable, "-m", "app.cli", *args], capture_output=True, text=True, cwd=cwd,
                          timeout=600)


def bad_files(tmp):
    doc, blob = quad_document("data")
    files = {}
    (tmp / "dir.glb").mkdir()
    files["directory"] = (str(tmp / "dir.glb"), "not a file")
    files["missing"] = (str(tmp / "none.obj"), "no such file")
    (tmp / "a.stl").write_text("solid")
    files["unsupported"] = (str(tmp / "a.stl"), "unsupported file type")
    good = write_glb(tmp / "good.glb", *quad_document(None))
    (tmp / "trunc.glb").write_bytes(good.read_bytes()[:40])
    files["truncated glb"] = (str(tmp / "trunc.glb"), "truncated")
    (tmp / "bad.gltf").write_text("{not json")
    files["malformed gltf"] = (str(tmp / "bad.gltf"), "malformed")
    d, _ = quad_document("../../outside.bin")
    files["escaping uri"] = (str(write_gltf(tmp / "esc.gltf", d)), "outside the scene's folder")
    nan = bytearray(blob)
    nan[4:8] = np.float32(np.inf).tobytes()
    d, _ = quad_document(None)
    files["non-finite"] = (str(write_glb(tmp / "inf.glb", d, bytes(nan))), "non-finite")
    idx = bytearray(blob)
    idx[130:132] = np.uint16(500).tobytes()
    files["index range"] = (str(write_glb(tmp / "idx.glb", d, bytes(idx))), "out of range")
    (tmp / "empty.obj").write_text("v 0 0 0\n")
    files["empty scene"] = (str(tmp / "empty.obj"), "no triangles")
    (tmp / "bad.ply").write_text("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nend_header\n1\n")
    files["malformed ply"] = (str(tmp / "bad.ply"), "")
    huge, _ = quad_document("data")
    for k in range(3):  # positions, normals, uvs: consistent counts that the machine cannot hold
        huge["accessors"][k]["count"] = 2_000_000_000
    files["too large"] = (str(write_gltf(tmp / "huge.gltf", huge)), "too large for this machine")
    huge["accessors"][0]["count"] = 4_000_000_000
    files["count past int32"] = (str(write_gltf(tmp / "huge2.gltf", huge)), "out of range 1..2147483647")
    return files


def test_every_bad_file_gives_one_line_and_status_2(tmp_path):
    for name, (path, needle) in bad_files(tmp_path).items():
        r = rtlab("shot", path, "--size", "16x16", "--out", str(tmp_path / "x.png"))
        lines = [x for x in r.stderr.splitlines() if x.strip()]
        assert r.returncode == 2, f"{name}: {r.returncode} {r.stderr}"
        assert "Traceback" not in r.stderr, name
        assert len(lines) == 1 and lines[0].startswith("rtlab: error:"), f"{name}: {r.stderr}"
        assert needle in lines[0], f"{name}: {lines[0]}"
        assert not (tmp_path / "x.png").exists()


@pytest.mark.parametrize("args,needle", [
    (["--out", "{tmp}"], ".png"),
    (["--out", "{tmp}/no/dir/x.png"], "does not exist"),
    (["--raw", "{tmp}/x.txt"], ".npy"),
    (["--pass", "gi", "--set", "gi.rays_per_pixel=0"], "out of range"),
    (["--pass", "gi", "--set", "gi.rays_per_pixel=1000"], "out of range"),
    (["--pass", "ao", "--set", "ao.radius=-1"], "out of range"),
    (["--pass", "ao", "--set", "ao.radius=nan"], "finite"),
    (["--set", "reflections.max_depth=x"], "integer"),
    (["--set", "shadows.lights=some"], "not one of all, one"),
    (["--pass", "nope"], "choose one of"),
])
def test_bad_options_and_outputs(tmp_path, args, needle):
    args = [a.replace("{tmp}", str(tmp_path)) for a in args]
    r = rtlab("shot", "arcade", "--size", "16x16", *args, cwd=tmp_path)
    assert r.returncode == 2 and "Traceback" not in r.stderr
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and needle in lines[0], r.stderr


def test_scene_without_lights_renders_and_says_so(tmp_path):
    (tmp_path / "dark.obj").write_text("v -1 0 -1\nv 1 0 -1\nv 0 0 1\nf 1 3 2\n")
    out = tmp_path / "d.png"
    r = rtlab("shot", str(tmp_path / "dark.obj"), "--pass", "ao", "--size", "32x32", "--out", str(out),
              "--set", "env=sky")
    assert r.returncode == 0, r.stderr
    assert "no lights of its own" in r.stderr and "studio" in r.stderr and "Traceback" not in r.stderr
    assert out.exists()


def degenerate_scene():
    b = SceneBuilder("degenerate")
    b.environment.kind = "sky"
    b.material("m", (0.5, 0.5, 0.5), roughness=0.1)
    b.material("glow", (1, 1, 1), emissive=(5, 5, 5))
    b.add(grid(2, 2), "m", trs((0, 0, 0), 0, (10, 1, 10)))
    b.add(grid(2, 2), "m", trs((0, 0, 0), 0, (10, 1, 10)))  # coincident with the floor
    b.add(box(), "m", trs((0, 1, 0), 0, (0.0, 1.0, 1.0)))  # zero-thickness box: zero-area faces
    b.add(box(), "glow", trs((2, 0.5, 0), 0, (1e-9, 1e-9, 1e-9)))  # emissive specks of ~0 area
    b.add(box(), "m", trs((-2, 1, 0), 0, (2, 2, 2)))
    b.light(kind="point", position=(-2, 1, 0), intensity=10.0)  # light inside the box
    b.light(kind="point", position=(0, 0, 0), intensity=10.0)  # light on the floor
    b.light(kind="spot", position=(0, 3, 0), direction=(0, -1, 0), intensity=10.0, inner_cone=0.5, outer_cone=0.5)
    b.view("inside", (-2.0, 1.0, 0.2), (-1.0, 1.0, 0.0), 60)  # camera inside the box
    b.view("outside", (0.0, 3.0, 6.0), (0.0, 0.0, 0.0), 60)
    return b.build()


@pytest.mark.parametrize("view", ["inside", "outside"])
def test_degenerate_geometry_gives_no_nan(gl, view):
    scene = degenerate_scene()
    r = Renderer(gl, scene, Options())
    cam = Camera.from_view(scene.views[view], scene.diagonal)
    for name in ("forward", "shadows", "reflections", "gi", "ao", "hybrid", "reference", "normal", "motion"):
        for gbuffer in ("raster", "rt"):
            r.options.set("gbuffer", gbuffer)
            r.render(cam, 48, 32, name)
            img = r.read_linear()
            assert np.isfinite(img).all(), f"{name} {gbuffer}"
    r.release()


def test_interrupted_write_leaves_nothing(tmp_path, monkeypatch):
    from PIL import Image

    from app.image_io import write_png

    def boom(*a, **k):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(Image.Image, "save", boom)
    with pytest.raises(UserError, match="No space left"):
        write_png(tmp_path / "x.png", np.zeros((4, 4, 3), np.uint8))
    assert list(tmp_path.iterdir()) == []


GLTF_BASE, _ = quad_document("data", image=png_bytes(np.full((2, 2, 3), 128, np.uint8)))
json_leaf = st.one_of(st.none(), st.booleans(), st.integers(-5, 2**33), st.floats(allow_nan=True),
                      st.text(max_size=8))


@st.composite
def mutated_gltf(draw):
    doc = json.loads(json.dumps(GLTF_BASE))
    for _ in range(draw(st.integers(1, 4))):
        path = []
        node = doc
        while isinstance(node, (dict, list)) and node and draw(st.booleans()):
            key = draw(st.sampled_from(sorted(node) if isinstance(node, dict) else list(range(len(node)))))
            path.append((node, key))
            node = node[key]
        if path:
            parent, key = path[-1]
            action = draw(st.sampled_from(["replace", "delete"]))
            if action == "delete" and isinstance(parent, dict):
                del parent[key]
            else:
                parent[key] = draw(json_leaf)
    return doc


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(doc=mutated_gltf())
def test_fuzz_gltf_loader(tmp_path, doc):
    path = tmp_path / "f.gltf"
    path.write_text(json.dumps(doc))
    try:
        scene = load_scene(str(path))
    except UserError as e:
        assert "\n" not in str(e)
    else:
        assert np.isfinite(scene.positions).all()
        assert scene.indices.max() < len(scene.positions)


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=st.binary(max_size=200))
def test_fuzz_glb_bytes(tmp_path, data):
    path = tmp_path / "f.glb"
    path.write_bytes(b"glTF" + data)
    try:
        load_scene(str(path))
    except UserError as e:
        assert "\n" not in str(e)


@settings(max_examples=300, deadline=None)
@given(key=st.one_of(st.sampled_from(Options().keys()), st.text(max_size=20)), value=st.text(max_size=20))
def test_fuzz_option_parser(key, value):
    opts = Options()
    try:
        opts.apply([f"{key}={value}"])
    except UserError as e:
        assert "\n" not in str(e)
    else:
        assert opts.get(key.strip()) is not None
