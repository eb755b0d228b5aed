"""Camera rays traced as packets of tiles of pixels (rtcIntersect8, rtcore.intersect_tiles) give
the same hits, to the bit, as one ray at a time: on a built-in scene, at sizes that leave part
tiles at the edges, and through the alpha filter of masked materials. So do the packets
that every other ray is traced in (rtcore.intersect_range, occluded_range; the generators'
shadow and AO rays through raygen._trace_add): incoherent rays, part packets at the end."""
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


def _incoherent_rays(scene, n, seed=3):
    """Rays from random points of random triangles in random directions, lengths 0.5-3."""
    rng = np.random.default_rng(seed)
    tri = rng.integers(0, len(scene.indices), n)
    w = rng.random((n, 2))
    w[w.sum(1) > 1] = 1 - w[w.sum(1) > 1]
    p = scene.positions[scene.indices[tri]].astype(np.float64)
    o = p[:, 0] + w[:, :1] * (p[:, 1] - p[:, 0]) + w[:, 1:] * (p[:, 2] - p[:, 0])
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    return (o + 1e-3 * d).astype(np.float32), d.astype(np.float32), (0.5 + 2.5 * rng.random(n)).astype(np.float32)


@pytest.mark.parametrize("n", [1, 15, 16, 17, 5003])
def test_packets_of_any_rays_find_what_single_rays_find(n):
    from rt.embree import rtcore

    scene = build_builtin("arcade")
    tracer = EmbreeTracer(scene.positions, scene.indices, threads=1)
    o, d, tmax = _incoherent_rays(scene, n)
    handle = tracer.inline_scene()
    t, prim = np.empty(n, np.float32), np.empty(n, np.int32)
    u, v = np.empty(n, np.float32), np.empty(n, np.float32)
    rtcore.intersect(handle, o, d, tmax, t, prim, u, v)
    blocked = np.empty(n, np.bool_)
    rtcore.occluded(handle, o, d, tmax, blocked)
    buf, b = rtcore.ray_buffer()
    words = buf.view(np.uint32)
    for i in range(n):  # one ray at a time, through the single-ray calls
        assert (t[i], prim[i], u[i], v[i]) == rtcore.intersect1(handle, buf, words, b, *o[i], *d[i], tmax[i])
        assert blocked[i] == rtcore.occluded1(handle, buf, words, b, *o[i], *d[i], tmax[i])
    assert blocked[prim >= 0].all() and not blocked[prim < 0].any()
    if n > 1000:
        assert 0.2 < blocked.mean() < 0.95
    tracer.close()


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
