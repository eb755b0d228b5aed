"""Option textures.max_size: a renderer's textures box-filtered down when memory is short, in
every pass and backend, the loaded scene left as it was."""
import numpy as np
import pytest

from scenes.builder import SceneBuilder, grid, trs
from scenes.texture_limit import limited, shrink
from tests.test_rt import make


def test_shrink_box_filters_to_the_longer_side():
    img = np.random.default_rng(0).random((64, 32, 3)).astype(np.float32)
    small = shrink(img, 16)
    assert small.shape == (16, 8, 3) and small.dtype == np.float32
    np.testing.assert_allclose(small[0, 0], img[:4, :4].mean((0, 1)), rtol=1e-5)
    odd = shrink(img[:60, :30], 16)  # no whole blocks: Pillow's box filter
    assert odd.shape == (16, 8, 3)
    np.testing.assert_allclose(odd.mean((0, 1)), img[:60, :30].mean((0, 1)), rtol=0.02)
    assert shrink(img, 64) is img and shrink(None, 8) is None


def _textured_floor(side=64):
    b = SceneBuilder("floor")
    b.material("tex", (1.0, 1.0, 1.0), roughness=1.0)
    b.add(grid(2, 2), "tex", trs((0, 0, 0), 0, (4, 1, 4)))
    b.light(kind="directional", position=(0, 5, 0), intensity=3.0)
    b.view("top", (0.0, 3.0, 2.0), (0.0, 0.0, 0.0), 60)
    scene = b.build()
    y, x = (np.mgrid[0:side, 0:side] + 0.5) / side
    s, c = np.sin(2 * np.pi * x), np.cos(2 * np.pi * y)  # smooth and periodic (wrap repeat): filters alike
    scene.materials[0].texture = np.stack([0.5 + 0.4 * s, 0.5 + 0.4 * c, 0.5 + 0 * x], -1).astype(np.float32)
    n = np.stack([0.3 * s, 0 * x, 1 + 0 * x], -1)
    scene.materials[0].normal_map = (n / np.linalg.norm(n, axis=-1, keepdims=True)).astype(np.float32)
    return scene


def test_limited_copies_once_and_leaves_the_scene():
    scene = _textured_floor()
    small = limited(scene, 16)
    assert small is not scene and limited(scene, 16) is small and limited(scene, 0) is scene
    assert small.materials[0].texture.shape == (16, 16, 3) and scene.materials[0].texture.shape == (64, 64, 3)
    np.testing.assert_allclose(np.linalg.norm(small.materials[0].normal_map, axis=-1), 1.0, rtol=1e-5)
    assert small.positions is scene.positions  # the geometry is shared


@pytest.mark.parametrize("tracer", ["embree", "vulkan"])
def test_a_smaller_texture_renders_alike_in_every_pass(gl, tracer):
    from app.camera import Camera

    scene = _textured_floor()
    cam = Camera.from_view(scene.default_view(), scene.diagonal)
    sets = ("jitter=false", f"tracer={tracer}")
    for pass_name in ("forward", "shadows"):
        full = make(gl, scene, sets)
        r = make(gl, scene, sets + ("textures.max_size=16",))
        full.render(cam, 48, 36, pass_name)
        r.render(cam, 48, 36, pass_name)
        assert max(r.scene.materials[0].texture.shape[:2]) == 16
        a, b = full.read_linear(), r.read_linear()
        assert a.mean() > 0.1
        np.testing.assert_allclose(b, a, atol=0.05, err_msg=pass_name)
        # changed at run time: the renderer's scene again, the loaded one as it was
        r.options.set("textures.max_size", "0")
        r.render(cam, 48, 36, pass_name)
        assert r.scene is scene and scene.materials[0].texture.shape == (64, 64, 3)
        np.testing.assert_allclose(r.read_linear(), a, atol=1e-5, err_msg=pass_name)
        full.release()
        r.release()


def test_many_textures_are_packed_each_in_its_layer(gl):
    """Over 8 layers the GL texture array is packed on threads: each layer still holds its own."""
    from app.raster.gpu_scene import GpuScene

    b = SceneBuilder("many")
    for k in range(12):
        b.material(f"m{k}", (1.0, 1.0, 1.0), roughness=1.0)
        b.add(grid(1, 1), f"m{k}", trs((k, 0, 0), 0, (1, 1, 1)))
    b.light(kind="directional", position=(0, 5, 0), intensity=1.0)
    scene = b.build()
    for k, m in enumerate(scene.materials):
        m.texture = np.full((4 + k, 8, 3), k / 16, np.float32)
    gpu = GpuScene(gl, scene)
    size = gpu.textures.size[0]
    texels = np.frombuffer(gpu.textures.read(), np.float16).reshape(12, size, size, 4)
    for k in range(12):
        np.testing.assert_allclose(texels[k, ..., :3], k / 16, atol=1e-3)
        np.testing.assert_array_equal(texels[k, ..., 3], 1.0)
    gpu.release()
