"""A closed room lets no light in: its point light outside, above the ceiling, must leave every
pixel of the room black in the ray-traced passes. Rays that cross the walls where their triangles
meet are what a non-robust traversal lets through (Embree without RTC_SCENE_FLAG_ROBUST: a few
pixels lit in GI's 48 accumulated frames, report/HISTORY.md); robust traversal lets none through."""
import pytest

from app.camera import Camera
from scenes.builder import SceneBuilder
from tests.scenes_for_tests import _room_walls
from tests.test_rt import make


def room_lit_from_outside():
    b = SceneBuilder("leak")
    b.material("wall", (0.5, 0.5, 0.5), roughness=1.0)
    b.material("red", (0.8, 0.1, 0.1), roughness=1.0)
    _room_walls(b)
    b.light(kind="point", position=(0.3, 4.0, 0.2), intensity=1000.0)  # the ceiling is at 3 m
    b.view("room", (0.0, 1.5, 1.9), (0.0, 1.0, -2.0), 70)
    return b.build()


PASSES = [("shadows", []), ("gi", ["gi.bounces=1", "gi.rays_per_pixel=4"])]


def lit_pixels(gl, tracer: str, pass_name: str, sets: list) -> int:
    scene = room_lit_from_outside()
    r = make(gl, scene, [f"tracer={tracer}", "gbuffer=rt"] + sets)
    cam = Camera.from_view(scene.default_view(), scene.diagonal)
    for _ in range(48):  # accumulated: a pixel lit by any frame stays lit
        r.render(cam, 256, 192, pass_name)
    lit = int((r.read_linear().max(-1) > 0).sum())
    r.release()
    return lit


@pytest.mark.parametrize("pass_name,sets", PASSES)
def test_no_light_leaks_into_a_closed_room(gl, pass_name, sets):
    assert lit_pixels(gl, "embree", pass_name, sets) == 0


@pytest.mark.parametrize("pass_name,sets", PASSES)
def test_no_light_leaks_into_a_closed_room_on_the_gpu_backend(gl, gpu_device, pass_name, sets):
    """The device's traversal (lavapipe here, OptiX or NVIDIA's Vulkan on a GPU) likewise."""
    assert lit_pixels(gl, gpu_device, pass_name, sets) == 0
