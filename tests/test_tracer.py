"""The Embree tracer on a single triangle: hits, occlusion and tmax, whole-array and chunked."""
import numpy as np
import pytest

from rt.tracer import INF, EmbreeTracer

TRIANGLE = (np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], np.float32), np.array([[0, 1, 2]], np.int32))


@pytest.mark.parametrize("threads", [1, 3])
def test_occlusion_respects_tmax_and_leaves_it_unchanged(threads):
    tracer = EmbreeTracer(*TRIANGLE, threads=threads, min_chunk=1)
    n = 5000
    o = np.tile(np.float32([0.2, 0.2, 1.0]), (n, 1))
    o[1::2, 0] = 5.0  # every other ray passes beside the triangle
    d = np.tile(np.float32([0, 0, -1]), (n, 1))
    tmax = np.where(np.arange(n) % 4 < 2, 2.0, 0.5).astype(np.float32)  # half stop short of it
    before = tmax.copy()
    blocked = tracer.occluded(o, d, tmax)
    assert np.array_equal(blocked, (np.arange(n) % 2 == 0) & (tmax > 1.0))
    assert np.array_equal(tmax, before)
    assert np.array_equal(tracer.occluded(o, d, 2.0), np.arange(n) % 2 == 0)  # a scalar tmax
    hits = tracer.intersect(o, d)
    assert np.array_equal(hits.hit, np.arange(n) % 2 == 0)
    assert np.allclose(hits.t[::2], 1.0) and np.all(hits.t[1::2] == INF)
    tracer.close()
