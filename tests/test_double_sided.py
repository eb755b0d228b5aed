"""glTF's `doubleSided: false` (the spec's default): a single-sided surface seen from behind is
not seen by the camera, in the raster G-buffer and forward pass (fragments of its back faces
discarded) and by primary rays on Embree and the device (they go on past it), so that the raster
and ray-traced G-buffers agree. Every other ray (shadows, AO, GI, reflections; the shadow maps)
sees both sides, as Mitsuba 3 (which culls nothing) and Cycles do: such a roof still casts its
shadow."""
import numpy as np
import pytest

from scenes.loaders import load_scene
from tests.gltf_writer import textured_scene, write_gltf
from tests.test_rt import run

SIZE = (48, 48)


def roof_scene(tmp_path, roof_facing: str, double_sided: bool = False):
    """A white double-sided floor (4 m, y = 0) under a 0.8 m grey roof at y = 1 facing
    `roof_facing` ("down": its back towards the camera), single-sided unless double_sided;
    a point light at 2.5 m and the camera at 3 m above, looking straight down."""
    materials = [{"pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1], "metallicFactor": 0.0,
                                           "roughnessFactor": 1.0}, "doubleSided": True},
                 {"pbrMetallicRoughness": {"baseColorFactor": [0.3, 0.3, 0.3, 1], "metallicFactor": 0.0,
                                           "roughnessFactor": 1.0}, "doubleSided": double_sided}]
    quads = [((0, 0, 0), 4.0, 0, "up"), ((0, 1, 0), 0.8, 1, roof_facing)]
    lights = [{"type": "point", "intensity": 30.0, "color": [1, 1, 1], "node": {"translation": [0, 2.5, 0]}}]
    half = -np.pi / 4  # looking down -y
    doc = textured_scene(materials, [], quads, lights, ((0, 3, 0), (float(np.sin(half)), 0, 0, float(np.cos(half))),
                                                        0.9))
    path = tmp_path / f"roof_{roof_facing}_{double_sided}.gltf"
    write_gltf(path, doc)
    return load_scene(str(path))


GBUFFERS = [("gbuffer=raster",), ("gbuffer=rt",), ("gbuffer=rt", "tracer=vulkan")]


@pytest.mark.parametrize("sets", GBUFFERS)
def test_the_back_of_a_single_sided_roof_is_not_seen(gl, tmp_path, sets):
    """Seen from behind, the single-sided roof is missing from the G-buffer (every pixel is the
    floor, y = 0); seen from the front, or double-sided, it is there (y = 1 in the middle)."""
    behind = run(gl, roof_scene(tmp_path, "down"), "position", size=SIZE, sets=sets)
    assert np.abs(behind[..., 1]).max() < 1e-3
    for scene in (roof_scene(tmp_path, "up"), roof_scene(tmp_path, "down", double_sided=True)):
        seen = run(gl, scene, "position", size=SIZE, sets=sets)
        assert seen[24, 24, 1] == pytest.approx(1.0, abs=1e-3)


def test_raster_and_ray_traced_gbuffers_agree(gl, tmp_path):
    scene = roof_scene(tmp_path, "down")
    for channel in ("position", "normal", "albedo"):
        raster = run(gl, scene, channel, size=SIZE, sets=("gbuffer=raster", "jitter=false"))
        traced = run(gl, scene, channel, size=SIZE, sets=("gbuffer=rt", "jitter=false"))
        assert np.abs(raster - traced).max() < 2e-3, channel


@pytest.mark.parametrize("pass_name,sets", [("shadows", ()), ("shadows", ("tracer=vulkan",)),
                                            ("forward", ("forward.shadow_maps=true",))])
def test_a_single_sided_roof_still_casts_its_shadow(gl, tmp_path, pass_name, sets):
    """Shadow rays (and the shadow maps) see both sides: under the unseen roof the floor is dark,
    outside it lit."""
    image = run(gl, roof_scene(tmp_path, "down"), pass_name, size=SIZE, sets=sets).mean(-1)
    assert image[22:26, 22:26].max() < 0.02 * image[2:6, 2:6].mean()
    assert image[2:6, 2:6].mean() > 0.1
