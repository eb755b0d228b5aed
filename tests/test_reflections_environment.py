"""The reflections pass under an environment: its lit points and mirror hits take the
environment's light (one sample each, as from a light), on the diffuse lobe alone where a mirror
ray brings the specular one, in a corner whose answers have closed forms."""
import numpy as np
import pytest

from app.camera import Camera
from tests.test_gi_environment import ALBEDO, corner
from tests.test_rt import run


def render(gl, scene, sets):
    cam = Camera(np.array([4.0, 2.0, 3.0]), np.array([0.0, 0.5, 0.0]), np.array([0.0, 1.0, 0.0]), 60)
    cam.fit_clip(scene.diagonal)
    sets = ("jitter=false", "env=1,1,1", *sets)
    pos = run(gl, scene, "position", size=(32, 24), camera=cam, sets=sets)[..., :3]
    covered = np.abs(pos).sum(-1) > 0
    assert covered.sum() > 300
    img = run(gl, scene, "reflections", size=(32, 24), camera=cam, frames=32, sets=sets)[..., :3]
    return img[covered]


@pytest.mark.parametrize("tracer", ["embree", "vulkan"])
def test_rough_points_are_lit_by_the_environment(gl, tracer):
    """Rough Lambert planes (no mirror ray) under a uniform sky of radiance 1: half of each
    point's hemisphere (cosine-weighted) is sky, so it leaves albedo / 2 (0 when the pass saw
    lights alone)."""
    scene = corner(color=(ALBEDO,) * 3, roughness=1.0)
    img = render(gl, scene, (f"tracer={tracer}", "brdf=lambert"))
    np.testing.assert_allclose(img.mean(0), ALBEDO / 2, rtol=0.015)


@pytest.mark.parametrize("tracer", ["embree", "vulkan"])
@pytest.mark.parametrize("depth", [1, 2])
def test_mirror_corner_counts_the_sky_once(gl, tracer, depth):
    """Smooth white metal (F = 1, no diffuse lobe) under a uniform sky of radiance 1: every point
    shows the sky after one or two mirrors, so 1 everywhere. With one mirror the wall's hits take
    the sky from their own GGX sample (was 0: lights alone); with two, their mirror ray brings it,
    and a sample of the specular lobe as well would count it twice (about 2)."""
    scene = corner(color=(1.0, 1.0, 1.0), roughness=0.0, metallic=1.0)
    img = render(gl, scene, (f"tracer={tracer}", "brdf=ggx", f"reflections.max_depth={depth}"))
    np.testing.assert_allclose(img.mean(0), 1.0, rtol=0.015)
    assert np.percentile(np.abs(img - 1.0), 95) < 0.05
