"""The GI pass under an environment: its bounce hits are lit by the environment too (one sample
each, as by a light), in a corner whose one-bounce light has a closed form."""
import numpy as np
import pytest

from app.camera import Camera
from scenes.builder import SceneBuilder, grid, trs
from tests.test_envmap import write_exr
from tests.test_rt import run

ALBEDO = 0.5


def corner(**material):
    """A floor (x > 0) and a wall (x = 0, facing +x), of one material (by default diffuse grey),
    400 m across and 200 m high: from any point of either, the half of the hemisphere towards
    the other is the other, the rest the sky."""
    b = SceneBuilder("corner")
    b.material("m", **(material or dict(color=(ALBEDO,) * 3, roughness=1.0)))
    b.add(grid(4, 4), "m", trs((200, 0, 0), 0, (400, 1, 400)))
    b.add(grid(4, 4), "m", trs((0, 100, 0), np.pi / 2, (400, 1, 200), rotate_x=np.pi / 2))
    b.view("corner", (4.0, 2.0, 3.0), (0.0, 0.5, 0.0), 60)
    return b.build()


@pytest.mark.parametrize("tracer", ["embree", "vulkan"])
@pytest.mark.parametrize("env", ["uniform", "map"])
def test_gi_bounce_hits_see_the_environment(gl, tmp_path, tracer, env):
    """Under a uniform sky of radiance 1, one bounce: a point gets 1/2 from the sky directly and
    1/2 x (the other plane's own sky light, albedo x 1/2), so it leaves albedo x (1/2 + albedo / 4)
    (0.3125; 0.25 when bounce hits saw lights alone). The same with the sky a uniform map, drawn
    from its distribution at the hits."""
    scene = corner()
    spec = "1,1,1" if env == "uniform" else write_exr(tmp_path / "white.exr", np.ones((16, 32, 3), np.float32))
    cam = Camera(np.array([4.0, 2.0, 3.0]), np.array([0.0, 0.5, 0.0]), np.array([0.0, 1.0, 0.0]), 60)
    cam.fit_clip(scene.diagonal)
    sets = ("jitter=false", f"tracer={tracer}", f"env={spec}", "brdf=lambert", "gi.bounces=1")
    pos = run(gl, scene, "position", size=(32, 24), camera=cam, sets=sets)[..., :3]
    covered = np.abs(pos).sum(-1) > 0
    assert covered.sum() > 300
    img = run(gl, scene, "gi", size=(32, 24), camera=cam, frames=48, sets=sets)[..., :3]
    want = ALBEDO * (0.5 + ALBEDO / 4)
    np.testing.assert_allclose(img[covered].mean(0), want, rtol=0.015)
    # unshadowed (the study's cheap GI): the hits' sky samples are not blocked, so each plane
    # counts the whole sky at its hits: albedo x (1/2 + albedo / 2)
    img = run(gl, scene, "gi", size=(32, 24), camera=cam, frames=48, sets=sets + ("gi.shadows=false",))[..., :3]
    np.testing.assert_allclose(img[covered].mean(0), ALBEDO * (0.5 + ALBEDO / 2), rtol=0.015)
