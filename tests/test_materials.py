"""glTF materials in every renderer: alpha-masked surfaces (seen through and casting cut
shadows), emission from textures (only the glowing part is a light), normal maps (bent
shading normals under a grazing sun), the occlusion-roughness-metallic layer; each checked
against analytic values on the raster path, on Embree and on Vulkan (lavapipe)."""
import json
import warnings

import numpy as np
import pytest

from app.camera import parse_camera
from scenes.loaders import load_scene
from tests.gltf_writer import textured_scene
from tests.test_rt import run

SUN_DOWN = {"rotation": [-0.7071068, 0, 0, 0.7071068]}  # the light's -Z turned to -Y
WHITE = {"pbrMetallicRoughness": {"baseColorFactor": [1, 1, 1, 1], "metallicFactor": 0, "roughnessFactor": 1}}
TRACERS = [("forward", ()), ("shadows", ("shadows.greyscale=true",)),
           ("shadows", ("shadows.greyscale=true", "tracer=vulkan"))]


def _write(tmp_path, doc, name="scene.gltf"):
    path = tmp_path / name
    path.write_text(json.dumps(doc))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # scenes without lights say so
        return load_scene(str(path))


def _leaf_texture():
    """Left half (u < 0.5) cut away, right half solid."""
    t = np.full((8, 8, 4), 255, np.uint8)
    t[:, :4, 3] = 0
    return t


def masked_scene(tmp_path):
    leaf = {"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}, "baseColorFactor": [0, 1, 0, 1],
                                     "metallicFactor": 0},
            "alphaMode": "MASK", "alphaCutoff": 0.5, "doubleSided": True}
    floor = {"pbrMetallicRoughness": {"baseColorFactor": [1, 0, 0, 1], "metallicFactor": 0}}
    doc = textured_scene([floor, leaf], [_leaf_texture()], [((0, 0, 0), 6, 0, "up"), ((0, 1, 0), 2, 1, "up")],
                         [{"type": "directional", "intensity": 3.0, "node": SUN_DOWN}])
    return _write(tmp_path, doc)


def _floor_x(width: int, half_extent: float) -> np.ndarray:
    """World x of each column for a camera looking straight down (image x = world +x)."""
    return (2 * (np.arange(width) + 0.5) / width - 1) * half_extent


@pytest.mark.parametrize("pass_name,sets", [("albedo", ()), ("albedo", ("gbuffer=rt",)),
                                            ("albedo", ("gbuffer=rt", "tracer=vulkan"))])
def test_masked_surface_is_seen_through_where_cut(gl, tmp_path, pass_name, sets):
    scene = masked_scene(tmp_path)
    assert scene.stats()["alpha_tested_materials"] == 1
    cam = parse_camera("eye=0,3,0;target=0,0,0;up=0,0,-1;fov=60", scene)
    img = run(gl, scene, pass_name, size=(64, 64), camera=cam, sets=sets)
    x = _floor_x(64, 3 * np.tan(np.radians(30)))
    rows = slice(24, 40)  # |z| < 0.4: under the leaf
    cut, solid = (x > -0.9) & (x < -0.1), (x > 0.1) & (x < 0.9)
    assert np.allclose(img[rows][:, cut], [1, 0, 0], atol=0.02), "the floor shows through the cut half"
    assert np.allclose(img[rows][:, solid], [0, 1, 0], atol=0.02), "the solid half is the leaf"


@pytest.mark.parametrize("pass_name,sets", TRACERS)
def test_masked_surface_casts_a_cut_shadow(gl, tmp_path, pass_name, sets):
    scene = masked_scene(tmp_path)
    cam = parse_camera("eye=0,0.9,0;target=0,0,0;up=0,0,-1;fov=90", scene)
    img = run(gl, scene, pass_name, size=(64, 64), camera=cam, sets=sets)[..., 0]
    x = _floor_x(64, 0.9)
    rows = slice(16, 48)
    lit, shadowed = img[rows][:, (x > -0.8) & (x < -0.15)], img[rows][:, (x > 0.15) & (x < 0.8)]
    assert lit.min() > 0.5 * lit.mean() > 0.0
    assert shadowed.max() < 0.05 * lit.mean(), "under the solid half: the sun is blocked"


def test_emission_comes_only_from_the_glowing_part_of_the_texture(gl, tmp_path):
    glow = np.zeros((8, 8, 3), np.uint8)
    glow[:2, 6:] = 255  # one corner glows: u > 0.75, v < 0.25 (x > 0.5, z < -0.5), in one triangle of the quad
    emitter = {"pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1], "metallicFactor": 0},
               "emissiveTexture": {"index": 0}, "emissiveFactor": [1, 1, 1],
               "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 20.0}}}
    doc = textured_scene([WHITE, emitter], [glow], [((0, 0, 0), 8, 0, "up"), ((0, 1, 0), 2, 1, "down")], [])
    scene = _write(tmp_path, doc)
    emission = scene.triangle_emission()
    emitter_tris = np.nonzero(scene.material_ids == 1)[0]
    power = emission[emitter_tris][:, 0] * scene.triangle_areas(emitter_tris)
    # the glowing texels cover (2/8)^2 of the quad's 4 m^2: power Le x 0.25 m^2, nearly all in one
    # triangle (the other sees the corner only through bilinear filtering across the repeat seam)
    assert power.sum() == pytest.approx(20.0 * 0.25, rel=0.1)
    assert power.min() < 0.05 * power.max()
    cam = parse_camera("eye=0,0.5,0;target=0,0,0;up=0,0,-1;fov=120", scene)
    for sets in ((), ("tracer=vulkan",)):
        img = run(gl, scene, "shadows", frames=8, size=(48, 48), camera=cam,
                  sets=("shadows.greyscale=true", "env=black") + sets)[..., 0]
        near, far = img[0:8, 40:48].mean(), img[40:48, 0:8].mean()  # under the glowing corner; the opposite one
        assert near > 3 * far > 0, sets


def test_normal_map_bends_the_shading_normal(gl, tmp_path):
    """A normal map tilted 30 degrees towards a sun 60 degrees from the zenith: the irradiance
    goes from E cos 60 (flat) to E cos 30, a ratio of sqrt(3), in every renderer."""
    n = np.array([np.sin(np.radians(30)), 0.0, np.cos(np.radians(30))])  # tangent space: +x is the tangent
    bumpy_tex = np.tile(np.round((n + 1) / 2 * 255), (4, 4, 1)).astype(np.uint8)
    bumpy = {**WHITE, "normalTexture": {"index": 0}}
    # a sun whose light travels along d = -(sin 60, cos 60, 0): the node turns its -Z onto d
    # (90 degrees about -Z x d)
    axis = np.array([-np.cos(np.radians(60)), np.sin(np.radians(60)), 0.0])
    q = [*(axis * np.sin(np.pi / 4)), np.cos(np.pi / 4)]
    sun = {"type": "directional", "intensity": 2.0, "node": {"rotation": q}}
    flat_doc = textured_scene([WHITE], [], [((0, 0, 0), 4, 0, "up")], [dict(sun)])
    bumpy_doc = textured_scene([bumpy], [bumpy_tex], [((0, 0, 0), 4, 0, "up")], [dict(sun)])
    flat, bent = _write(tmp_path, flat_doc, "flat.gltf"), _write(tmp_path, bumpy_doc, "bumpy.gltf")
    direction = np.asarray(flat.lights[0].direction)
    assert np.degrees(np.arccos(-direction[1])) == pytest.approx(60, abs=0.5) and direction[0] < 0, direction
    cam = parse_camera("eye=0,2,0;target=0,0,0;up=0,0,-1;fov=40", flat)
    for pass_name, sets in TRACERS:
        a = run(gl, flat, pass_name, size=(32, 32), camera=cam, sets=sets)[8:24, 8:24, 0].mean()
        b = run(gl, bent, pass_name, size=(32, 32), camera=cam, sets=sets)[8:24, 8:24, 0].mean()
        assert b / a == pytest.approx(np.sqrt(3), rel=0.03), (pass_name, sets)


@pytest.mark.parametrize("sets", [(), ("gbuffer=rt",), ("gbuffer=rt", "tracer=vulkan")])
def test_roughness_and_metallic_come_from_their_texture(gl, tmp_path, sets):
    """metallicRoughnessTexture: G is roughness, B metallic, times their factors."""
    mr = np.zeros((4, 4, 3), np.uint8)
    mr[..., 1], mr[..., 2] = 128, 255
    mat = {"pbrMetallicRoughness": {"metallicRoughnessTexture": {"index": 0}, "roughnessFactor": 0.5,
                                    "metallicFactor": 0.8}}
    doc = textured_scene([mat], [mr], [((0, 0, 0), 4, 0, "up")], [{"type": "directional", "node": SUN_DOWN}])
    scene = _write(tmp_path, doc)
    cam = parse_camera("eye=0,2,0;target=0,0,0;up=0,0,-1;fov=40", scene)
    rough = run(gl, scene, "roughness", size=(16, 16), camera=cam, sets=sets)[4:12, 4:12, 0]
    metal = run(gl, scene, "metallic", size=(16, 16), camera=cam, sets=sets)[4:12, 4:12, 0]
    assert rough.mean() == pytest.approx(0.5 * 128 / 255, abs=0.01)
    assert metal.mean() == pytest.approx(0.8, abs=0.01)


@pytest.mark.parametrize("tracer", ["embree", "vulkan"])
def test_dark_albedo_survives_the_packed_gbuffer(gl, tracer):
    """The raster G-buffer reaches the ray tracers packed to 8 bits a channel, sRGB-encoded: a
    dark channel (0.0138) keeps its value within 2 % (8-bit linear would round it to 0.0157)."""
    from tests.scenes_for_tests import lit_plane

    albedo = (0.0138, 0.05, 0.6)
    scene = lit_plane(albedo)
    img = run(gl, scene, "ao", size=(32, 24), sets=("ao.greyscale=false", "ao.radius=0.001", f"tracer={tracer}"))
    covered = img.sum(-1) > 0
    assert covered.sum() > 100
    np.testing.assert_allclose(np.median(img[covered], axis=0), albedo, rtol=0.02)


@pytest.mark.parametrize("pass_name,sets", [("albedo", ()), ("albedo", ("gbuffer=rt",)),
                                            ("albedo", ("gbuffer=rt", "tracer=vulkan"))])
def test_vertex_colours_tint_the_base_colour(gl, tmp_path, pass_name, sets):
    """COLOR_0 (linear) times baseColorFactor, interpolated over the triangle."""
    doc = textured_scene([{"pbrMetallicRoughness": {"baseColorFactor": [0.5, 1, 1, 1], "metallicFactor": 0}}], [],
                         [((0, 0, 0), 4, 0, "up")], [])
    colours = np.array([[1, 0, 0], [1, 0, 0], [0, 0, 1], [0, 0, 1]], np.float32)  # x: -2..2 red, z: -2 red, +2 blue
    blob = __import__("base64").b64decode(doc["buffers"][0]["uri"].split(",", 1)[1]) + colours.tobytes()
    doc["bufferViews"].append({"buffer": 0, "byteOffset": len(blob) - colours.nbytes, "byteLength": colours.nbytes})
    doc["accessors"].append({"bufferView": len(doc["bufferViews"]) - 1, "componentType": 5126, "count": 4,
                             "type": "VEC3"})
    doc["meshes"][0]["primitives"][0]["attributes"]["COLOR_0"] = len(doc["accessors"]) - 1
    doc["buffers"][0] = {"byteLength": len(blob),
                         "uri": "data:application/octet-stream;base64," + __import__("base64").b64encode(blob).decode()}
    scene = _write(tmp_path, doc)
    assert scene.colors is not None
    cam = parse_camera("eye=0,3,0;target=0,0,0;up=0,0,-1;fov=60", scene)
    img = run(gl, scene, pass_name, size=(32, 32), camera=cam, sets=sets)
    z = (2 * (np.arange(32) + 0.5) / 32 - 1) * 3 * np.tan(np.radians(30))  # each row's z (image top: -z)
    t = (z + 2) / 4  # red at z = -2 to blue at z = +2
    want = np.stack([0.5 * (1 - t), np.zeros(32), t], 1)  # times baseColorFactor (0.5, 1, 1)
    np.testing.assert_allclose(img[:, 12:20].mean(axis=1), want, atol=0.03)


@pytest.mark.parametrize("sets", [(), ("gbuffer=rt",), ("gbuffer=rt", "tracer=vulkan")])
@pytest.mark.parametrize("mag", [9728, 9729])
def test_sampler_nearest_or_linear(gl, tmp_path, sets, mag):
    """A 2x2 texture, red left, green right: magFilter NEAREST reads the texel a point falls in
    (pure red at u = 0.3), LINEAR blends with the next (bilinear: 0.9 red, 0.1 green there)."""
    tex = np.zeros((2, 2, 3), np.uint8)
    tex[:, 0, 0] = 255
    tex[:, 1, 1] = 255
    mat = {"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}, "metallicFactor": 0}}
    doc = textured_scene([mat], [tex], [((0, 0, 0), 2, 0, "up")], [{"type": "directional", "node": SUN_DOWN}])
    doc["samplers"] = [{"magFilter": mag, "minFilter": 9729}]
    doc["textures"][0]["sampler"] = 0
    scene = _write(tmp_path, doc)
    assert scene.materials[0].nearest == (mag == 9728)
    cam = parse_camera("eye=0,1,0;target=0,0,0;up=0,0,-1;fov=90", scene)
    img = run(gl, scene, "albedo", size=(100, 100), camera=cam, sets=sets)
    x = _floor_x(100, 1.0)
    col = np.argmin(np.abs(x + 0.4))  # u = 0.3
    red = img[40:60, col, 0].mean()
    assert red == pytest.approx(1.0 if mag == 9728 else 0.9, abs=0.02)
