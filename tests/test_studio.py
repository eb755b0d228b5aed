"""Default lighting: a scene file with no lights of its own opens under the studio environment,
the same gradient on every backend and in the raster passes."""
import warnings
from pathlib import Path

import numpy as np
import pytest

from app.camera import Camera
from scenes.loaders import lit_by_itself, load_scene
from scenes.model import STUDIO_GROUND, STUDIO_HORIZON, STUDIO_ZENITH, Environment
from tests.gltf_writer import mesh_scene, uv_sphere, write_gltf
from tests.test_rt import run

SUZANNE = Path(__file__).resolve().parents[2] / "shared" / "assets" / "suzanne" / "Suzanne.gltf"


def _sphere_file(tmp_path, lights=(), emissive=(0.0, 0.0, 0.0)):
    pos, nrm, uv, idx = uv_sphere((0.0, 0.0, 0.0), 1.0, 16, 8)
    mat = {"pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1.0], "metallicFactor": 0.0},
           "emissiveFactor": list(emissive)}
    path = tmp_path / "sphere.gltf"
    write_gltf(path, mesh_scene([(pos, nrm, uv, idx, 0)], [mat], list(lights)))
    return str(path)


def test_studio_gradient_ends():
    env = Environment.parse("studio")
    d = np.array([[0, 1, 0], [0, -1, 0], [1, 0, 0]], np.float32)
    np.testing.assert_allclose(env.radiance(d), [STUDIO_ZENITH, STUDIO_GROUND, STUDIO_HORIZON], rtol=1e-6)
    assert env.to_string() == "studio"


def test_a_file_without_lights_opens_under_the_studio(tmp_path):
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        scene = load_scene(_sphere_file(tmp_path))
    assert scene.environment.kind == "studio"
    assert any("studio environment" in str(w.message) for w in seen)
    light = {"type": "point", "intensity": 10.0, "color": [1, 1, 1], "node": {"translation": [0, 3, 0]}}
    assert load_scene(_sphere_file(tmp_path, [light])).environment.kind == "black"
    # a surface of constant emission lights the scene; built-ins keep their own environment
    assert load_scene(_sphere_file(tmp_path, emissive=(1.0, 1.0, 1.0))).environment.kind == "black"
    assert load_scene("arcade").environment.kind == "black"


@pytest.mark.skipif(not SUZANNE.exists(), reason="shared/assets not present")
def test_suzanne_is_lit_on_first_open():
    """The Khronos Suzanne (no lights, no emission) under the studio, forward and ray-traced."""
    scene = load_scene(str(SUZANNE))
    assert not lit_by_itself(scene) and scene.environment.kind == "studio"


@pytest.mark.parametrize("tracer", ["embree", "vulkan"])
def test_studio_background_is_the_same_in_every_pass(gl, tmp_path, tracer):
    """The background of a view looking up, away from the sphere: the studio's gradient in the
    forward pass (GL) and in a ray-traced pass on each backend; its centre is the zenith."""
    scene = load_scene(_sphere_file(tmp_path))
    cam = Camera(np.array([0.0, 5.0, 0.0]), np.array([0.0, 10.0, 0.0]), np.array([0.0, 0.0, 1.0]), 60)
    cam.fit_clip(scene.diagonal)
    sets = ("jitter=false", f"tracer={tracer}")
    forward = run(gl, scene, "forward", size=(16, 12), camera=cam, sets=sets)[..., :3]
    traced = run(gl, scene, "ao", size=(16, 12), camera=cam, sets=sets)[..., :3]
    sky = run(gl, scene, "ao", size=(16, 12), camera=cam, sets=sets + ("env=sky",))[..., :3]
    np.testing.assert_allclose(traced, forward, rtol=2e-3, atol=2e-3)
    np.testing.assert_allclose(traced[5:7, 7:9], np.broadcast_to(STUDIO_ZENITH, (2, 2, 3)), rtol=0.02)
    assert np.abs(sky - traced).max() > 0.1  # the studio, not the sky


@pytest.mark.parametrize("env", ["studio", "0.1,0.2,0.3"])
@pytest.mark.parametrize("tracer", ["embree", "vulkan"])
def test_env_intensity_scales_the_environment_in_every_pass(gl, tmp_path, env, tracer):
    scene = load_scene(_sphere_file(tmp_path))
    cam = Camera(np.array([0.0, 5.0, 0.0]), np.array([0.0, 10.0, 0.0]), np.array([0.0, 0.0, 1.0]), 60)
    cam.fit_clip(scene.diagonal)
    for pass_name in ("forward", "ao"):
        one, two = (run(gl, scene, pass_name, size=(16, 12), camera=cam,
                        sets=("jitter=false", f"tracer={tracer}", f"env={env}", f"env.intensity={k}"))[..., :3]
                    for k in (1, 2))
        assert one.min() > 0.05, pass_name
        np.testing.assert_allclose(two, 2.0 * one, rtol=2e-3, err_msg=pass_name)
