"""Big scenes on the device (rt/slang/scene.py; common.slang: Mesh): the indexed layout (INDEXED_FROM),
the vertices' own normals, uvs, tangents and colours read through the index buffer and face
normals made from the vertices, and textures as half floats (HALF_TEXELS_FROM). Forced on small
scenes here, they must give what the per-triangle rows and float texels give: the same images as
Embree on the same random numbers, and every material feature (normal maps, vertex colours,
alpha masks, single-sided faces, texture filtering), in less device memory."""
import numpy as np
import pytest

import rt.slang.scene as device_scene
from scenes.builtin import build_builtin
from tests import test_double_sided, test_materials, test_slang


@pytest.fixture
def indexed(monkeypatch):
    monkeypatch.setattr(device_scene, "INDEXED_FROM", 0)


@pytest.fixture
def half(monkeypatch):
    monkeypatch.setattr(device_scene, "HALF_TEXELS_FROM", 0)


@pytest.mark.parametrize("pass_name,name,sets", [
    ("gi", "arcade", ("brdf=ggx",)), ("reflections", "temple", ("reflections.max_depth=3",)),
    ("reference", "cafe", ()), ("albedo", "temple", ()),
])
def test_big_scene_layout_matches_embree_on_the_same_numbers(gl, vulkan, indexed, half, pass_name, name, sets):
    test_slang.test_effects_match_embree_on_the_same_numbers(gl, vulkan, pass_name, name, sets)


@pytest.mark.parametrize("halves", [False, True])
def test_big_scene_layout_keeps_every_material_feature(gl, tmp_path, vulkan, indexed, monkeypatch, halves):
    if halves:
        monkeypatch.setattr(device_scene, "HALF_TEXELS_FROM", 0)
    vk = ("gbuffer=rt", "tracer=vulkan")
    test_materials.test_normal_map_bends_the_shading_normal(gl, tmp_path)  # its Vulkan case under the layout
    test_materials.test_vertex_colours_tint_the_base_colour(gl, tmp_path, "albedo", vk)
    test_materials.test_masked_surface_is_seen_through_where_cut(gl, tmp_path, "albedo", vk)
    test_double_sided.test_the_back_of_a_single_sided_roof_is_not_seen(gl, tmp_path, vk)
    for mag in (9728, 9729):  # nearest and linear texture filtering
        test_materials.test_sampler_nearest_or_linear(gl, tmp_path, vk, mag)


def test_big_scene_layout_takes_less_device_memory(vulkan, monkeypatch):
    from rt.slang.device import open_device

    scene = build_builtin("street")
    rows = device_scene.DeviceScene(open_device("vulkan"), scene)
    monkeypatch.setattr(device_scene, "INDEXED_FROM", 0)
    indexed = device_scene.DeviceScene(open_device("vulkan"), scene)
    assert rows.corner_rows == 4 and indexed.corner_rows == 0
    # the street's 84,916 triangles: 80 bytes a triangle of rows and face normals against 20 bytes a vertex
    # and 4 a triangle
    assert indexed.device_bytes < rows.device_bytes - 40 * len(scene.indices)
    monkeypatch.setattr(device_scene, "HALF_TEXELS_FROM", 0)
    half = device_scene.DeviceScene(open_device("vulkan"), scene)
    assert half.half_texels == 1
    assert half.device_bytes == pytest.approx(indexed.device_bytes - 8 * len(indexed.arrays.tex_data), abs=64)


def test_textures_beyond_half_floats_stay_float():
    texels = np.full((3 << 20, 4), 0.5, np.float32)
    assert device_scene.half_texels(texels).dtype == np.float16
    for bad in (7e4, np.inf, np.nan):
        texels[2 << 20, 1] = bad
        assert device_scene.half_texels(texels) is None, bad
