"""Multiple importance sampling in the reference path tracer (reference.mis; rt/embree/reference.py,
shaders/rt/reference.slang): light sampling and the diffuse bounce's hits on emitters weighted by
the power heuristic converge to the same image as light sampling alone, with less noise where a
large emitter is close (next-event estimation's 1 / d^2 there), on Embree and Vulkan."""
import numpy as np
import pytest

from app.camera import Camera
from scenes.builder import SceneBuilder, grid, trs
from tests.test_rt import make

SIZE = (48, 32)
# On Vulkan the reference's MIS is also held to Embree's on the same numbers (test_slang's parity
# cases: the cafe's reference, MIS on); these two cost 2-5 min on lavapipe: --runslow
VULKAN = pytest.param(("tracer=vulkan",), marks=pytest.mark.slow, id="vulkan")


def lamp(size, height, eye):
    """A square one-sided lamp facing down over a grey floor."""
    b = SceneBuilder("lamp")
    b.environment.kind = "black"
    b.material("floor", (0.6, 0.6, 0.6), roughness=1.0)
    b.material("lamp", (0.0, 0.0, 0.0), roughness=1.0, emissive=(4.0, 4.0, 4.0))
    b.add(grid(4, 4), "floor", trs((0, 0, 0), 0, (8, 1, 8)))
    b.add(grid(1, 1), "lamp", trs((0, height, 0), 0, (size, 1, size), rotate_x=np.pi))
    b.view("view", eye, (0.0, 0.0, 0.0), 40)
    return b.build()


def image(gl, scene, sets, frames, seed):
    r = make(gl, scene, ("reference.max_bounces=2", "reference.rr_start=8") + sets)
    r.seed = seed
    cam = Camera.from_view(scene.default_view(), scene.diagonal)
    for _ in range(frames):
        r.render(cam, *SIZE, "reference")
    out = r.read_linear()
    r.release()
    return out


@pytest.mark.parametrize("sets", [(), VULKAN])
def test_mis_converges_to_what_light_sampling_does(gl, sets):
    """A 0.6 m lamp 1 m up, where both estimators are calm: the same floor, within 0.5 %."""
    scene = lamp(0.6, 1.0, (0.0, 2.0, 3.0))
    with_mis, without = (image(gl, scene, sets + (f"reference.mis={m}",), 64, 1) for m in ("true", "false"))
    lit = without.sum(-1) > 1e-3
    assert with_mis[lit].mean() == pytest.approx(without[lit].mean(), rel=0.005)


@pytest.mark.parametrize("sets", [(), VULKAN])
def test_mis_removes_the_noise_of_a_close_lamp(gl, sets):
    """A 2 m lamp 0.15 m above the floor, seen from beside it: next-event estimation's 1 / d^2
    makes fireflies under it, which the cosine-weighted bounce's share removes (measured: the
    difference between two seeds' 32-frame images falls from 0.54 to 0.063 RMS)."""
    scene = lamp(2.0, 0.15, (0.0, 0.08, 2.5))
    noise = {}
    for mis in ("true", "false"):
        a, b = (image(gl, scene, sets + (f"reference.mis={mis}",), 32, seed) for seed in (1, 2))
        lit = a.sum(-1) > 1e-3
        noise[mis] = float(np.sqrt(np.mean((a[lit] - b[lit]) ** 2)))
    print(f"{sets}: noise between seeds {noise}")
    assert noise["true"] < 0.3 * noise["false"]
