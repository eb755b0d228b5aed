"""FBX and Assimp's other formats (scenes/loaders/assimp.py): files written by Assimp's own
exporter from rtlab's glTF test scenes render as their glTF sources on every pass; DDS textures
decode to the pixels of the same image as PNG; a broken file gives one line; the importer runs in
a child process."""
import shutil
import struct
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

from app.camera import Camera
from core.errors import UserError
from scenes.loaders import load_scene
from tests.gltf_writer import mesh_scene, uv_sphere, write_gltf
from tests.test_rt import run

pytest.importorskip("pyassimp")
pytest.importorskip("assimp_py")
ASSETS = Path(__file__).resolve().parents[2] / "shared" / "assets"
EXPORT = """
import sys, pyassimp
from pyassimp import postprocess as pp
with pyassimp.load(sys.argv[1], processing=pp.aiProcess_Triangulate) as scene:
    pyassimp.export(scene, sys.argv[2], "fbxa")
"""


def export_fbx(src: Path, dst: Path) -> Path:
    """src written as FBX by Assimp's exporter, in a process of its own. ASCII FBX: the binary
    FBX that Assimp 5.2's exporter writes is unreadable for its own importer ("block offset is out
    of range"); its FBX exporter also leaves out lights, cameras and metal-rough parameters."""
    subprocess.run([sys.executable, "-c", EXPORT, str(src), str(dst)], check=True, capture_output=True, timeout=120)
    return dst


def hierarchy_document():
    """Spheres under a small node tree (translation, rotation, non-uniform scale, a mirrored
    child), one of them emissive (a light for the ray-traced passes), no lights or camera."""
    colours = [(0.8, 0.2, 0.1), (0.1, 0.6, 0.2), (0.2, 0.3, 0.9), (0.9, 0.9, 0.9)]
    materials = [{"pbrMetallicRoughness": {"baseColorFactor": [*c, 1], "metallicFactor": 0.0}} for c in colours]
    materials[3]["emissiveFactor"] = [1.0, 0.9, 0.7]
    meshes = [(*uv_sphere((0.0, 0.0, 0.0), 0.5, 32, 16), k) for k in range(4)]
    doc = mesh_scene(meshes, materials, [])
    half = float(np.sqrt(0.5))
    doc["nodes"] = [
        {"mesh": 0, "translation": [-1.2, 0.0, 0.0], "children": [1]},
        {"mesh": 1, "translation": [0.0, 1.1, 0.0], "rotation": [0.0, 0.0, half, half], "scale": [1.0, 0.6, 1.0],
         "children": [2]},
        {"mesh": 2, "translation": [1.2, 0.0, 0.0], "scale": [-1.0, 1.0, 1.0]},
        {"mesh": 3, "translation": [1.3, 0.2, 0.6], "scale": [0.4, 0.4, 0.4]},
    ]
    doc["scenes"] = [{"nodes": [0, 3]}]
    return doc


def write_textured(folder: Path) -> Path:
    """hierarchy_document with a checker PNG (a file beside it) on the first sphere."""
    from PIL import Image

    folder.mkdir(parents=True, exist_ok=True)
    y, x = np.mgrid[0:16, 0:32]
    checker = np.where(((x // 4 + y // 4) % 2)[..., None] == 0, [230, 200, 40], [30, 60, 200]).astype(np.uint8)
    Image.fromarray(checker).save(folder / "checker.png")
    doc = hierarchy_document()
    doc["images"], doc["textures"] = [{"uri": "checker.png"}], [{"source": 0}]
    doc["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"] = {"index": 0}
    return write_gltf(folder / "tree.gltf", doc)


def _pair(tmp_path, name):
    if name == "suzanne":
        if not (ASSETS / "suzanne").is_dir():
            pytest.skip("shared/assets not present")
        folder = tmp_path / "suzanne"
        shutil.copytree(ASSETS / "suzanne", folder)
        gltf = folder / "Suzanne.gltf"
    else:
        gltf = write_textured(tmp_path / "tree")
    return load_scene(str(gltf)), load_scene(str(export_fbx(gltf, gltf.with_suffix(".fbx"))))


@pytest.mark.parametrize("name", ["suzanne", "textured"])
def test_fbx_from_assimp_has_the_gltf_geometry_and_materials(tmp_path, name):
    src, fbx = _pair(tmp_path, name)
    np.testing.assert_allclose(fbx.bounds()[0], src.bounds()[0], atol=1e-4)
    np.testing.assert_allclose(fbx.bounds()[1], src.bounds()[1], atol=1e-4)
    assert fbx.triangle_count == src.triangle_count
    assert np.isclose(fbx.triangle_areas().sum(), src.triangle_areas().sum(), rtol=1e-4)
    def used(scene):  # the materials its triangles use, by colour and emission
        return sorted((scene.materials[k] for k in np.unique(scene.material_ids)),
                      key=lambda m: (*m.base_color[:3], *m.emissive))

    for a, b in zip(used(fbx), used(src), strict=True):
        np.testing.assert_allclose(a.base_color[:3], b.base_color[:3], atol=1e-3)
        np.testing.assert_allclose(a.emissive, b.emissive, atol=1e-3)
        assert (a.texture is None) == (b.texture is None)
        if a.texture is not None:
            np.testing.assert_allclose(a.texture[..., :3], b.texture[..., :3], atol=1e-6)


@pytest.mark.parametrize("name", ["suzanne", "textured"])
@pytest.mark.parametrize("pass_name, frames", [("forward", 1), ("shadows", 1), ("ao", 2), ("gi", 2),
                                               ("reflections", 1), ("reference", 4)])
def test_fbx_renders_as_its_gltf_source(gl, tmp_path, name, pass_name, frames):
    """Every pass, the same camera and options (brdf=lambert: Assimp's FBX exporter keeps the
    base colour, its texture and the emission, not the metal-rough parameters)."""
    src, fbx = _pair(tmp_path, name)
    cam = Camera.from_view(src.default_view(), src.diagonal)
    sets = ("brdf=lambert", "env=sky", "jitter=false")
    a = run(gl, src, pass_name, frames=frames, size=(64, 48), camera=cam, sets=sets)[..., :3]
    b = run(gl, fbx, pass_name, frames=frames, size=(64, 48), camera=cam, sets=sets)[..., :3]
    diff = np.abs(a - b)
    assert diff.mean() < 0.01 * max(a.mean(), 1e-3) + 1e-4, (diff.mean(), a.mean())
    assert np.percentile(diff, 99) < 0.05 * max(a.max(), 1e-3), np.percentile(diff, 99)


def _dds_rgba8(rgba: np.ndarray) -> bytes:
    """An uncompressed 32-bit DDS (DDPF_RGB | DDPF_ALPHAPIXELS, R8G8B8A8)."""
    h, w = rgba.shape[:2]
    pf = struct.pack("<II4sIIIII", 32, 0x41, b"\0\0\0\0", 32, 0xFF, 0xFF00, 0xFF0000, 0xFF000000)
    header = struct.pack("<I I I I I I I 11I", 124, 0x100F, h, w, w * 4, 0, 1, *([0] * 11)) + pf + \
        struct.pack("<5I", 0x1000, 0, 0, 0, 0)
    return b"DDS " + header + np.ascontiguousarray(rgba, np.uint8).tobytes()


def _dds_bc1(colours: np.ndarray) -> bytes:
    """A BC1 DDS of 4x4 blocks, block (i, j) one exact RGB565 colour colours[i, j] (every index
    0), so that its decoded pixels are known."""
    bh, bw = colours.shape[:2]
    pf = struct.pack("<II4sIIIII", 32, 0x4, b"DXT1", 0, 0, 0, 0, 0)
    header = struct.pack("<I I I I I I I 11I", 124, 0x81007, bh * 4, bw * 4, bh * bw * 8, 0, 1, *([0] * 11)) + pf + \
        struct.pack("<5I", 0x1000, 0, 0, 0, 0)
    blocks = b""
    for i in range(bh):
        for j in range(bw):
            r, g, b = (int(x) for x in colours[i, j])
            c = (r << 11) | (g << 5) | b
            blocks += struct.pack("<HHI", c, c, 0)
    return b"DDS " + header + blocks


def test_dds_textures_decode_to_their_pixels():
    from scenes.loaders.assimp import _decode

    rng = np.random.default_rng(2)
    rgba = rng.integers(0, 256, (8, 16, 4), dtype=np.uint8)
    rgba[..., 3] = 255
    got = _decode(_dds_rgba8(rgba), "test", ".dds", srgb=False, alpha=False)
    np.testing.assert_allclose(got, rgba[..., :3] / 255.0, atol=1e-6)
    c565 = rng.integers(0, [32, 64, 32], (2, 3, 3))
    got = _decode(_dds_bc1(c565), "test", ".dds", srgb=False, alpha=False)
    want = np.round(c565 * (255.0 / np.array([31, 63, 31]))) / 255.0
    np.testing.assert_allclose(got[::4, ::4], want, atol=1.5 / 255)
    assert got.shape == (8, 12, 3)


def test_fbx_with_a_dds_texture_renders_as_with_its_png(gl, tmp_path):
    """The checker as an uncompressed DDS, named from the FBX by a Windows path from another
    machine: found by its file name in the scene's folder, the same pixels and image."""
    gltf = write_textured(tmp_path / "tree")
    fbx = export_fbx(gltf, gltf.with_suffix(".fbx"))
    png = load_scene(str(fbx))
    from PIL import Image

    rgba = np.asarray(Image.open(gltf.parent / "checker.png").convert("RGBA"))
    (gltf.parent / "checker.dds").write_bytes(_dds_rgba8(rgba))
    text = fbx.read_text(encoding="latin-1").replace('"checker.png"', '"C:\\\\Users\\\\artist\\\\maps\\\\checker.dds"')
    assert "checker.dds" in text
    fbx.write_text(text, encoding="latin-1")
    dds = load_scene(str(fbx))
    textured = [k for k, m in enumerate(png.materials) if m.texture is not None]
    assert len(textured) == 1
    np.testing.assert_allclose(dds.materials[textured[0]].texture, png.materials[textured[0]].texture, atol=1e-6)
    cam = Camera.from_view(png.default_view(), png.diagonal)
    a, b = (run(gl, sc, "forward", size=(48, 36), camera=cam, sets=("brdf=lambert",)) for sc in (png, dds))
    np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("data, words", [(b"garbage" * 10, "Assimp cannot read it"),
                                         (b"Kaydara FBX Binary  \x00\x1a\x00" + b"\xff" * 64, "Assimp cannot read it")])
def test_broken_fbx_gives_one_line(tmp_path, data, words):
    path = tmp_path / "broken.fbx"
    path.write_bytes(data)
    with pytest.raises(UserError) as e:
        load_scene(str(path))
    assert words in str(e.value) and "\n" not in str(e.value)


def test_cli_opens_an_fbx(tmp_path):
    gltf = write_textured(tmp_path / "tree")
    fbx = export_fbx(gltf, gltf.with_suffix(".fbx"))
    out = tmp_path / "shot.png"
    r = subprocess.run([sys.executable, "-m", "app.cli", "shot", str(fbx), "--size", "64x48", "--out", str(out)],
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    assert out.stat().st_size > 0


def test_collada_light_and_camera_reach_the_scene(gl, tmp_path):
    """tests/data/lit_floor.dae (written by hand: Assimp's exporters abort on scenes with
    lights): a grey Lambert floor under a point light of colour (10, 8, 6) in a translated node,
    seen from a rotated camera node. The light lands where its node puts it and lights the floor
    as albedo / pi x I cos / d^2 (I: the file's colour, W/sr); the camera becomes the default view."""
    path = tmp_path / "lit_floor.dae"
    shutil.copy(Path(__file__).parent / "data" / "lit_floor.dae", path)
    scene = load_scene(str(path))
    assert len(scene.lights) == 1 and scene.lights[0].kind == "point"
    light = scene.lights[0]
    np.testing.assert_allclose(light.position, (0.5, 2.0, 0.0), atol=1e-5)
    np.testing.assert_allclose(light.radiance_scale, (10.0, 8.0, 6.0), rtol=1e-5)
    view = scene.default_view()
    np.testing.assert_allclose(view.eye, (0.0, 3.0, 5.0), atol=1e-4)
    direction = np.subtract(view.target, view.eye)
    np.testing.assert_allclose(direction / np.linalg.norm(direction), np.array([0, -3, -5]) / np.sqrt(34), atol=1e-4)
    cam = Camera.from_view(view, scene.diagonal)
    pos = run(gl, scene, "position", size=(48, 32), camera=cam).astype(np.float64)
    got = run(gl, scene, "shadows", size=(48, 32), camera=cam, sets=("env=black", "jitter=false"))
    floor = (np.abs(pos[..., 0]) < 1.8) & (np.abs(pos[..., 2]) < 1.8) & (np.abs(pos).sum(-1) > 0)
    to_light = np.asarray(light.position) - pos
    d2 = (to_light ** 2).sum(-1)
    want = 0.5 / np.pi * (np.array([10.0, 8.0, 6.0]) * (to_light[..., 1] / d2 ** 1.5)[..., None])
    assert floor.sum() > 300
    np.testing.assert_allclose(got[floor][:, :3], want[floor], rtol=0.01, atol=1e-4)


def test_embedded_textures_are_read_from_the_file(tmp_path):
    """A texture the file carries (Assimp's "*0"; FBX's embedded media the same way, by index
    or by file name): the same texels as the glTF reader decodes from that file, with nothing
    beside it on disk."""
    from scenes.loaders.assimp import load_assimp
    from tests.gltf_writer import png_bytes, quad_document, write_glb

    rgb = np.zeros((8, 8, 3), np.uint8)
    rgb[:4, :, 0], rgb[4:, :, 2], rgb[:, :4, 1] = 255, 200, 90
    doc, blob = quad_document(None, image=png_bytes(rgb))
    path = write_glb(tmp_path / "quad.glb", doc, blob)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no "not found"/"using the colour" warning
        mat = load_assimp(path).materials[0]
    want = load_scene(str(path)).materials[0].texture
    assert mat.texture is not None and mat.texture.shape[:2] == (8, 8)
    np.testing.assert_allclose(mat.texture[..., :3], want[..., :3], atol=1e-6)


def test_embedded_textures_by_file_name_and_as_texels(tmp_path):
    """FBX's embedded media are named by the file they came from (a path from another machine):
    found by that name; texels Assimp hands over decoded (BGRA made RGBA) read as their PNG."""
    from scenes.loaders.assimp import _embedded, _texture
    from tests.gltf_writer import png_bytes

    rgba = np.random.default_rng(1).integers(0, 256, (4, 6, 4)).astype(np.uint8)
    rgba[..., 3] = 255
    infos = [{"name": "D:\\art\\tex\\Wood.png", "hint": "png"}, {"name": "", "hint": "rgba8", "shape": [4, 6, 4]}]
    arrays = {"embedded_0": np.frombuffer(png_bytes(rgba[..., :3]), np.uint8), "embedded_1": rgba.reshape(-1)}
    carried = _embedded(infos, arrays)
    assert not arrays  # taken out of the scene's arrays
    scene_file = tmp_path / "s.fbx"
    by_name = _texture(scene_file, "C:\\Users\\someone\\wood.png", "s.fbx", srgb=False, embedded=carried)
    texels = _texture(scene_file, "*1", "s.fbx", srgb=False, alpha=True, embedded=carried)
    np.testing.assert_allclose(by_name, rgba[..., :3] / 255.0, atol=1e-6)
    np.testing.assert_allclose(texels, rgba / 255.0, atol=1e-6)
