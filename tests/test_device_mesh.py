"""The device's indexed mesh layout (rt/slang/scene.py, INDEXED_FROM; common.slang: Mesh), which
big scenes get: the vertices' own normals, uvs, tangents and colours read through the index
buffer, face normals made from the vertices. Forced on small scenes here, it must give what the
per-triangle rows give: the same images as Embree on the same random numbers, and every
material feature the rows carry (normal maps, vertex colours, alpha masks, single-sided
faces), in less device memory."""
import pytest

import rt.slang.scene as device_scene
from scenes.builtin import build_builtin
from tests import test_double_sided, test_materials, test_slang


@pytest.fixture
def indexed(monkeypatch):
    monkeypatch.setattr(device_scene, "INDEXED_FROM", 0)


@pytest.mark.parametrize("pass_name,name,sets", [
    ("gi", "arcade", ("brdf=ggx",)), ("shadows", "cafe", ()), ("reflections", "temple", ("reflections.max_depth=3",)),
    ("reference", "cafe", ()), ("albedo", "temple", ()), ("normal", "temple", ()), ("ao", "street", ("env=sky",)),
])
def test_indexed_layout_matches_embree_on_the_same_numbers(gl, vulkan, indexed, pass_name, name, sets):
    test_slang.test_effects_match_embree_on_the_same_numbers(gl, vulkan, pass_name, name, sets)


def test_indexed_layout_keeps_every_material_feature(gl, tmp_path, vulkan, indexed):
    vk = ("gbuffer=rt", "tracer=vulkan")
    test_materials.test_normal_map_bends_the_shading_normal(gl, tmp_path)  # its Vulkan case under the layout
    test_materials.test_vertex_colours_tint_the_base_colour(gl, tmp_path, "albedo", vk)
    test_materials.test_masked_surface_is_seen_through_where_cut(gl, tmp_path, "albedo", vk)
    test_double_sided.test_the_back_of_a_single_sided_roof_is_not_seen(gl, tmp_path, vk)


def test_indexed_layout_takes_less_device_memory(vulkan, monkeypatch):
    from rt.slang.device import open_device

    scene = build_builtin("street")
    rows = device_scene.DeviceScene(open_device("vulkan"), scene)
    monkeypatch.setattr(device_scene, "INDEXED_FROM", 0)
    indexed = device_scene.DeviceScene(open_device("vulkan"), scene)
    assert rows.corner_rows == 4 and indexed.corner_rows == 0
    # the street's 84,916 triangles: 80 bytes a triangle of rows and face normals against 20 bytes a vertex
    # and 4 a triangle
    assert indexed.device_bytes < rows.device_bytes - 40 * len(scene.indices)
