"""Camera rays traced as packets of 4 x 4 pixels (rtcIntersect16, rtcore.intersect_tiles) give
the same hits, to the bit, as one ray at a time: on a built-in scene, at sizes that leave part
tiles at the edges, and through the alpha filter of masked materials."""
import numpy as np
import pytest

from app.camera import Camera
from rt.embree.alpha import AlphaData
from rt.embree.kernels import camera_rays
from rt.embree.shading import SceneData
from rt.embree.tracer import EmbreeTracer
from scenes.builtin import build_builtin
from tests.test_materials import masked_scene


def _rays(camera, width, height):
    n = width * height
    r, u, f = (x.astype(np.float64) for x in camera.basis())
    o, d = np.empty((n, 3), np.float32), np.empty((n, 3), np.float32)
    camera_rays(camera.eye.astype(np.float64), r, u, f, float(np.tan(np.radians(camera.fov) / 2)),
                np.array([0.3, -0.2]), width, height, o, d)
    return o, d


def _same_hits(tracer, camera, width, height):
    o, d = _rays(camera, width, height)
    one, packets = tracer.intersect(o, d), tracer.intersect_image(o, d, width, height)
    for a, b in ((one.t, packets.t), (one.prim, packets.prim), (one.u, packets.u), (one.v, packets.v)):
        assert np.array_equal(a, b)
    return one


@pytest.mark.parametrize("size", [(64, 48), (37, 23), (1, 1), (5, 3)])
@pytest.mark.parametrize("threads", [1, 2])
def test_packets_hit_what_single_rays_hit(size, threads):
    scene = build_builtin("temple")
    tracer = EmbreeTracer(scene.positions, scene.indices, threads=threads)
    hits = _same_hits(tracer, Camera.from_view(scene.default_view(), scene.diagonal), *size)
    assert tracer.rays_traced == 2 * size[0] * size[1]
    if size[0] > 8:
        assert hits.hit.any()


def test_packets_pass_the_alpha_filter(tmp_path):
    scene = masked_scene(tmp_path)
    data = SceneData(scene)
    tracer = EmbreeTracer(scene.positions, scene.indices, alpha=AlphaData(data))
    cam = Camera(np.array([0.0, 3.0, 0.0]), np.array([0.0, 0.0, 0.0]), np.array([0.0, 0.0, -1.0]), 60)
    hits = _same_hits(tracer, cam, 64, 64)
    leaf = data.material_ids[hits.prim[hits.hit]] == 1
    assert 0 < leaf.mean() < 1  # the leaf's solid half is hit, its cut half seen through


def test_recorded_camera_rays_are_the_g_buffers_and_replay_as_packets():
    """bench --perf: camera rays traced as an image are logged as the G-buffer's ("primary",
    with the image's size), left out of a pass's replay, and replayed alone as packets."""
    from rt.backends import ray_log

    scene = build_builtin("arcade")
    tracer = EmbreeTracer(scene.positions, scene.indices, threads=2)
    camera = Camera.from_view(scene.default_view(), scene.diagonal)
    o, d = _rays(camera, 37, 23)
    tracer.recording = log = ray_log(16)
    tracer.intersect_image(o, d, 37, 23)
    tracer.recording = None
    batches = log.all_batches()
    assert [(b[0], b[1].shape[0], b[4]) for b in batches] == [("primary", 37 * 23, (37, 23))]
    assert tracer.replay(batches) >= 0 and tracer.replay_primary(batches) > 0
    assert tracer.replay_primary([]) >= 0
    tracer.close()
