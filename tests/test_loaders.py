import numpy as np
import pytest

from core.errors import UserError
from scenes.loaders import load_scene
from tests.gltf_writer import png_bytes, quad_document, write_glb, write_gltf


def check_quad(scene):
    assert scene.triangle_count == 2
    np.testing.assert_allclose(scene.positions[:, 1], 1.0)  # node translation applied
    np.testing.assert_allclose(scene.normals, np.tile([0, 1, 0], (4, 1)), atol=1e-6)
    m = scene.materials[scene.material_ids[0]]
    assert m.name == "glow" and m.double_sided
    np.testing.assert_allclose(m.base_color, [0.5, 0.25, 1.0, 1.0])
    np.testing.assert_allclose(m.emissive, [4.0, 2.0, 1.0])  # factor x KHR_materials_emissive_strength
    assert m.roughness == pytest.approx(0.3) and m.metallic == 0.0
    kinds = [li.kind for li in scene.lights]
    assert kinds == ["point", "spot", "directional"]
    point, spot, sun = scene.lights
    assert point.intensity == 12.0 and point.position == pytest.approx((0, 3, 0))
    np.testing.assert_allclose(point.radiance_scale, [12, 6, 3])
    assert spot.inner_cone == pytest.approx(0.2) and spot.outer_cone == pytest.approx(0.5)
    np.testing.assert_allclose(spot.direction, [0, -1, 0], atol=1e-6)  # -Z rotated -90 deg about X
    np.testing.assert_allclose(sun.direction, [0, -1, 0], atol=1e-6)
    cam = scene.views["front"]
    assert cam.eye == pytest.approx((0, 2, 5)) and cam.fov == pytest.approx(np.degrees(0.8))
    np.testing.assert_allclose(np.subtract(cam.target, cam.eye), [0, 0, -1], atol=1e-6)
    assert scene.default_view().name == "front"


def test_gltf_round_trip_with_texture(tmp_path):
    texture = np.zeros((4, 4, 3), np.uint8)
    texture[:2] = (255, 0, 0)
    texture[2:] = (0, 0, 255)
    doc, _ = quad_document("data", image=png_bytes(texture))
    scene = load_scene(str(write_gltf(tmp_path / "quad.gltf", doc)))
    check_quad(scene)
    tex = scene.materials[0].texture
    assert tex.shape == (4, 4, 3) and tex.dtype == np.float32
    np.testing.assert_allclose(tex[0, 0], [1, 0, 0])  # sRGB 255 -> linear 1; row 0 is the image's top
    np.testing.assert_allclose(tex[3, 0], [0, 0, 1])


def test_gltf_external_buffer_and_glb(tmp_path):
    doc, blob = quad_document("quad.bin")
    (tmp_path / "quad.bin").write_bytes(blob)
    check_quad(load_scene(str(write_gltf(tmp_path / "quad.gltf", doc))))
    doc, blob = quad_document(None)
    check_quad(load_scene(str(write_glb(tmp_path / "quad.glb", doc, blob))))


def test_undecodable_texture_falls_back_with_warning(tmp_path):
    doc, _ = quad_document("data", image=b"not a png at all")
    with pytest.warns(UserWarning, match="cannot decode"):
        scene = load_scene(str(write_gltf(tmp_path / "q.gltf", doc)))
    assert scene.materials[0].texture is None


def test_obj_with_mtl_and_ply(tmp_path):
    (tmp_path / "m.mtl").write_text("newmtl red\nKd 1 0 0\n")
    (tmp_path / "tri.obj").write_text("mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 0 -1\nvn 0 1 0\n"
                                      "usemtl red\nf 1//1 2//1 3//1\n")
    with pytest.warns(UserWarning, match="no lights"):
        s = load_scene(str(tmp_path / "tri.obj"))
    assert s.triangle_count == 1 and not s.lights
    np.testing.assert_allclose(s.materials[0].base_color[:3], [1, 0, 0], atol=1e-6)
    np.testing.assert_allclose(s.normals[0], [0, 1, 0], atol=1e-6)
    (tmp_path / "t.ply").write_text("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                                    "property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
                                    "end_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n")
    with pytest.warns(UserWarning, match="no lights"):
        s = load_scene(str(tmp_path / "t.ply"))
    assert s.triangle_count == 1
    np.testing.assert_allclose(np.abs(s.normals[0]), [0, 0, 1], atol=1e-6)


def _bad_cases(tmp_path):
    doc, blob = quad_document("data")
    cases = {}
    cases["missing"] = (str(tmp_path / "nope.gltf"), "no such file")
    (tmp_path / "x.step").write_text("x")
    cases["extension"] = (str(tmp_path / "x.step"), "unsupported file type")
    (tmp_path / "broken.gltf").write_text('{"asset": {"version": "2.0"}, "nodes": [')
    cases["malformed json"] = (str(tmp_path / "broken.gltf"), "malformed glTF JSON")
    good = write_glb(tmp_path / "good.glb", *quad_document(None))
    (tmp_path / "trunc.glb").write_bytes(good.read_bytes()[:60])
    cases["truncated glb"] = (str(tmp_path / "trunc.glb"), "truncated")
    d, _ = quad_document("../secret.bin")
    cases["escaping uri"] = (str(write_gltf(tmp_path / "esc.gltf", d)), "outside the scene's folder")
    d, _ = quad_document("/etc/passwd")
    cases["absolute uri"] = (str(write_gltf(tmp_path / "abs.gltf", d)), "must lie in the scene's folder")
    d, _ = quad_document("data", image_uri="../../etc/hostname")
    cases["escaping image"] = (str(write_gltf(tmp_path / "img.gltf", d)), "outside the scene's folder")
    nan_blob = bytearray(blob)
    nan_blob[0:4] = np.float32(np.nan).tobytes()
    d, _ = quad_document(None)
    cases["non-finite"] = (str(write_glb(tmp_path / "nan.glb", d, bytes(nan_blob))), "non-finite")
    bad_idx = bytearray(blob)
    bad_idx[128:130] = np.uint16(9).tobytes()
    cases["index range"] = (str(write_glb(tmp_path / "idx.glb", d, bytes(bad_idx))), "out of range")
    d2, _ = quad_document("data")
    d2["bufferViews"][0]["byteLength"] = 10_000
    cases["view past buffer"] = (str(write_gltf(tmp_path / "v.gltf", d2)), "runs past")
    (tmp_path / "bad.obj").write_text("mtllib ../../etc/x.mtl\nv 0 0 0\n")
    cases["obj escaping mtl"] = (str(tmp_path / "bad.obj"), "outside the scene's folder")
    (tmp_path / "empty.obj").write_text("# nothing\n")
    cases["empty obj"] = (str(tmp_path / "empty.obj"), "no triangles")
    (tmp_path / "idx.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n")
    cases["obj index"] = (str(tmp_path / "idx.obj"), "")
    (tmp_path / "bad.ply").write_bytes(b"ply\nformat binary_little_endian 1.0\nelement vertex 99\n")
    cases["truncated ply"] = (str(tmp_path / "bad.ply"), "")
    return cases


def test_bad_inputs_raise_one_clear_error(tmp_path):
    for name, (path, needle) in _bad_cases(tmp_path).items():
        with pytest.raises(UserError) as e:
            load_scene(path)
        msg = str(e.value)
        assert "\n" not in msg, name
        assert needle in msg, f"{name}: {msg}"


def _mesh_summary(positions, triangles):
    """Triangle count, total area and the sorted triangle centroids: what any two correct
    readers of the same file agree on, whatever their vertex order or splitting."""
    p = np.asarray(positions, np.float64)[np.asarray(triangles)]
    area = 0.5 * np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)
    centroids = np.round(p.mean(axis=1), 5)
    return len(p), area.sum(), centroids[np.lexsort(centroids.T)]


@pytest.mark.parametrize("kind", ["obj", "ascii", "binary_little_endian", "binary_big_endian"])
def test_obj_and_ply_readers_agree_with_trimesh(tmp_path, kind):
    """rtlab reads OBJ and PLY itself (checked values, no outside reads); trimesh, an independent
    parser, must see the same surface in the same files: quads and a pentagon fanned, negative
    OBJ indices, uvs and normals."""
    trimesh = pytest.importorskip("trimesh")
    rng = np.random.default_rng(3)
    verts = rng.uniform(-1, 1, (12, 3)).astype(np.float32)
    polys = [[0, 1, 2, 3], [4, 5, 6], [7, 8, 9, 10, 11], [0, 4, 8]]  # 2 + 1 + 3 + 1 triangles
    if kind.startswith("binary"):  # trimesh reads binary PLY lists of one length only
        polys = [[0, 1, 2, 3], [4, 5, 6, 7], [8, 9, 10, 11], [0, 4, 8, 1]]
    if kind == "obj":
        lines = [f"v {x:.6f} {y:.6f} {z:.6f}" for x, y, z in verts] + ["vt 0.25 0.5", "vn 0 1 0"]
        lines += ["f " + " ".join(f"{i - 12}/-1/1" for i in poly) for poly in polys]
        path = tmp_path / "m.obj"
        path.write_text("\n".join(lines) + "\n")
    else:
        header = (f"ply\nformat {kind} 1.0\nelement vertex 12\nproperty float x\nproperty float y\nproperty float z\n"
                  f"element face {len(polys)}\nproperty list uchar int vertex_indices\nend_header\n")
        if kind == "ascii":
            body = "".join(f"{x:.6f} {y:.6f} {z:.6f}\n" for x, y, z in verts)
            body += "".join(f"{len(p)} " + " ".join(map(str, p)) + "\n" for p in polys)
            data = (header + body).encode()
        else:
            o = "<" if kind == "binary_little_endian" else ">"
            data = header.encode() + verts.astype(o + "f4").tobytes()
            data += b"".join(np.array([len(p)], "u1").tobytes() + np.array(p, o + "i4").tobytes() for p in polys)
        path = tmp_path / "m.ply"
        path.write_bytes(data)
    with pytest.warns(UserWarning, match="no lights"):
        ours = load_scene(str(path))
    theirs = trimesh.load(str(path), force="mesh", process=False)
    a, b = _mesh_summary(ours.positions, ours.indices), _mesh_summary(theirs.vertices, theirs.faces)
    assert a[0] == b[0] == sum(len(p) - 2 for p in polys)
    assert a[1] == pytest.approx(b[1], rel=1e-5)
    np.testing.assert_allclose(a[2], b[2], atol=2e-5)
    if kind == "obj":
        np.testing.assert_allclose(ours.uvs, [[0.25, 0.5]] * len(ours.uvs), atol=1e-6)  # v flipped: glTF's down
        np.testing.assert_allclose(ours.normals, [[0, 1, 0]] * len(ours.normals), atol=1e-6)
