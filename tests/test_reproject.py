"""Reprojection (option reproject; app/raster/reproject.py, shaders/accumulate_reproject.frag):
the accumulated mean follows its points through camera motion and restarts where the surface
changes; a still camera accumulates exactly as without it; on every backend."""
import numpy as np
import pytest

from app.camera import Camera
from tests.test_denoise import EXACT, H, camera, frames
from tests.test_offsets import planes
from tests.test_rt import make


def test_a_still_camera_accumulates_as_without_reprojection(gl):
    still = [camera()] * 8
    a, _ = frames(gl, ("accumulate=true", "reproject=false"), still)
    b, _ = frames(gl, ("accumulate=true", "reproject=true"), still)
    np.testing.assert_allclose(a, b, atol=1e-6)


@pytest.mark.parametrize("sets", [(), ("tracer=vulkan",), ("gbuffer=rt",)])
def test_the_mean_follows_a_moving_camera(gl, sets):
    """Eight frames flying forward over AO between planes, exact value (h / r)^2 everywhere on
    the floor: reprojected, the last frame holds about eight frames' samples (the study's reset
    leaves one frame's noise), and the mean stays exact."""
    moving = [camera(-0.05 * k) for k in range(8)]
    reset, floor = frames(gl, sets + ("accumulate=true", "reproject=false"), moving)
    carried, _ = frames(gl, sets + ("accumulate=true", "reproject=true"), moving)
    inner = floor[8:-8, 8:-8]
    a, b = reset[8:-8, 8:-8][inner], carried[8:-8, 8:-8][inner]
    print(f"{sets}: std {a.std():.4f} reset, {b.std():.4f} reprojected; mean {b.mean():.4f}")
    assert b.std() < 0.3 * a.std()
    assert abs(b.mean() - EXACT) < 0.01


def test_the_mean_restarts_where_the_surface_changes(gl):
    """A jump to an unrelated view of the same floor restarts every pixel (count 1 in the mean's
    alpha); a small step keeps most of them."""
    far = Camera(np.array([50.0, 0.5, 50.0]), np.array([50.0, 0.0, 49.7]), np.array([0.0, 1.0, 0.0]), 60)
    far.fit_clip(planes(H).diagonal)
    r = make(gl, planes(H), ("ao.radius=2", "reproject=true"))
    counts = []
    for cam in (camera(), camera(), camera(-0.02), far):
        r.render(cam, 48, 32, "ao")
        counts.append(np.frombuffer(r.accumulation.ping["c"].read(), np.float32).reshape(32, 48, 4)[..., 3])
    r.release()
    floor = counts[0] > 0
    assert (counts[1] == 2).all()
    assert (counts[2][floor] == 3).mean() > 0.9  # a small step: nearly every point seen again
    assert (counts[3][floor] == 1).all()


def test_a_reset_with_the_camera_still_starts_from_this_frame(gl):
    """After a reset (here another option) with the camera where it was, the reprojected mean
    starts from the new frame alone, whatever the history texture held before (another
    option's mean, or none where the backend accumulated those frames itself: finish=tracer)."""
    for before in ("finish=gl", "finish=tracer"):
        r = make(gl, planes(H), ("ao.radius=2", "reproject=false", before))
        for _ in range(3):
            r.render(camera(), 48, 32, "ao")
        r.options.set("reproject", "true")
        r.options.set("ao.radius", "1")
        r.render(camera(), 48, 32, "ao")
        counts = np.frombuffer(r.accumulation.ping["c"].read(), np.float32).reshape(32, 48, 4)[..., 3]
        mean = r.read_linear()
        r.release()
        fresh = make(gl, planes(H), ("ao.radius=1", "reproject=true"))
        fresh.render(camera(), 48, 32, "ao")
        np.testing.assert_array_equal(counts[counts > 0], 1.0, err_msg=before)
        np.testing.assert_allclose(mean, fresh.read_linear(), atol=1e-6, err_msg=before)
        fresh.release()
