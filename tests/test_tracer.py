"""The Embree tracer: on a single triangle (hits, occlusion and tmax, whole-array and chunked),
and Embree called directly against embreex's own binding on a built-in scene."""
import numpy as np
import pytest

from rt.embree.tracer import INF, EmbreeTracer

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


def test_direct_embree_calls_match_embreex():
    """rt/embree/rtcore.py's kernels give embreex's results to the bit on random rays through the
    arcade: hits, distances, barycentrics and occlusion (struct layout, flags, robust mode)."""
    from embreex import rtcore_scene as rtcs
    from embreex.mesh_construction import TriangleMesh

    from rt.embree import rtcore as embree
    from scenes.loaders import load_scene

    scene = load_scene("arcade")
    ours = embree.EmbreeScene(scene.positions, scene.indices)
    theirs = rtcs.EmbreeScene()
    TriangleMesh(theirs, np.ascontiguousarray(scene.positions, np.float32),
                 np.ascontiguousarray(scene.indices, np.int32))
    rng = np.random.default_rng(5)
    n = 20000
    lo, hi = scene.positions.min(0), scene.positions.max(0)
    o = (lo + (hi - lo) * rng.random((n, 3))).astype(np.float32)
    d = rng.normal(size=(n, 3)).astype(np.float32)
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    tmax = rng.uniform(0.1, 5.0, n).astype(np.float32)
    blocked = np.empty(n, bool)
    embree.occluded(ours.handle, o, d, tmax, blocked)
    assert np.array_equal(blocked, theirs.run(o, d, dists=tmax.copy(), query="OCCLUDED") >= 0)
    assert 0.05 < blocked.mean() < 0.95
    t, prim = np.empty(n, np.float32), np.empty(n, np.int32)
    u, v = np.empty(n, np.float32), np.empty(n, np.float32)
    embree.intersect(ours.handle, o, d, np.full(n, INF, np.float32), t, prim, u, v)
    ref = theirs.run(o, d, output=1)
    assert np.array_equal(prim, ref["primID"]) and (prim >= 0).mean() > 0.5
    hit = prim >= 0
    assert np.array_equal(t[hit], ref["tfar"][hit]) and np.all(t[~hit] == INF)
    assert np.array_equal(u[hit], ref["u"][hit]) and np.array_equal(v[hit], ref["v"][hit])
    ours.close()


@pytest.mark.parametrize("workers", [1, 3])
def test_parallel_kernels_trace_as_the_serial_ones(workers):
    """The replay kernels (bench --perf's raw time), a worker on each of the tracer's threads,
    give the serial kernels' results."""
    from rt.embree import rtcore as embree
    from rt.embree.blocks import FRAME_BLOCK
    from rt.embree.tracer import EmbreeTracer

    positions = np.random.default_rng(2).uniform(-1, 1, (3000, 3)).astype(np.float32)
    indices = np.arange(3000, dtype=np.int32).reshape(-1, 3)
    tracer = EmbreeTracer(positions, indices, threads=workers)
    rng = np.random.default_rng(3)
    n = 5 * FRAME_BLOCK[0] + 77  # blocks for every worker, and a short last one
    o = rng.uniform(-1.5, 1.5, (n, 3)).astype(np.float32)
    d = rng.normal(size=(n, 3)).astype(np.float32)
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    tmax = rng.uniform(0.1, 3.0, n).astype(np.float32)
    a, b = np.empty(n, bool), np.empty(n, bool)
    embree.occluded(tracer.handle, o, d, tmax, a)
    tracer.run_parallel(embree.occluded_blocks, n, tracer.handle, o, d, tmax, b)
    assert np.array_equal(a, b) and 0.05 < a.mean() < 0.95
    first = [np.empty(n, np.float32), np.empty(n, np.int32), np.empty(n, np.float32), np.empty(n, np.float32)]
    second = [np.empty_like(x) for x in first]
    embree.intersect(tracer.handle, o, d, tmax, *first)
    tracer.run_parallel(embree.intersect_blocks, n, tracer.handle, o, d, tmax, *second)
    assert all(np.array_equal(x, y) for x, y in zip(first, second, strict=True)) and (first[1] >= 0).any()
    tracer.close()


def test_kernel_cache_follows_every_source(tmp_path):
    """Compiled kernels are cached per version of all of rt/embree/'s sources: a change to any
    one module (whose code other modules' kernels carry) moves the cache."""
    import shutil
    from pathlib import Path

    from rt.embree import process

    src = tmp_path / "embree"
    shutil.copytree(Path(process.__file__).parent, src, ignore=shutil.ignore_patterns("__pycache__"))
    first = process.cache_dir(src)
    assert process.cache_dir(src) == first
    (src / "raygen.py").write_text((src / "raygen.py").read_text() + "\n# changed\n")
    assert process.cache_dir(src) != first


def test_freed_scratch_is_reused_without_page_faults():
    """The Embree backend's process set-up keeps freed memory for reuse (rt/embree/memory.py,
    rt/embree/process.py, run by conftest): a worker thread's second round
    of frame-sized scratch arrays lands on pages it already touched (glibc's defaults: ~1,300
    faults here)."""
    import ctypes
    import threading

    from rt.embree import process

    process.init()  # sets malloc's thresholds (once per process)

    if not hasattr(ctypes.CDLL(None), "gnu_get_libc_version"):
        pytest.skip("malloc's thresholds are glibc's")
    import resource

    def round_of_scratch():
        for mb in (0.4, 1.2, 0.4, 2, 0.4, 5, 0.4):
            a, b = np.ones(int(mb * (1 << 18)), np.float32), np.ones(int(mb * (1 << 18)), np.float32)
            del a, b

    faults = []

    def worker():
        round_of_scratch()
        before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
        round_of_scratch()
        faults.append(resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before)

    t = threading.Thread(target=worker)
    t.start()
    t.join()
    assert faults[0] < 100


@pytest.mark.parametrize("n,workers", [(0, 2), (1, 2), (5000, 2), (40000, 1), (921600, 1), (580000, 2), (921600, 2),
                                       (921600, 16)])
def test_frame_blocks_cover_every_point_once_and_shrink_at_the_end(n, workers):
    from rt.embree.blocks import FRAME_BLOCK, block_bounds, block_size
    from rt.embree.kernels import next_block

    bounds = block_bounds(n, workers)
    assert bounds[0] == 0 and bounds[-1] == n
    sizes = np.diff(bounds)
    assert (sizes > 0).all() and (sizes <= block_size(n, workers)).all()
    assert (sizes[:-1] >= min(FRAME_BLOCK[0], n)).all()  # only the last may be short
    if workers > 1 and n >= 100_000:  # the last blocks shrink, so the workers finish together
        assert sizes[-1] < sizes[0] / 4 and (np.diff(sizes) <= 0).all()
    if workers == 1:  # nobody to wait for: blocks of block_size to the end
        assert (sizes[:-1] == block_size(n, workers)).all()
    counter = np.zeros(1, np.int64)  # the workers' view: each block once, then (n, n)
    taken = [next_block(counter, bounds) for _ in range(len(sizes) + 2)]
    assert [b for b in taken if b[0] < n] == list(zip(bounds[:-1], bounds[1:], strict=True))
    assert taken[-1] == (n, n)


def test_tracing_threads_flush_denormals():
    """Work on the tracer's threads runs with flush-to-zero and denormals-are-zero set (Embree's
    advice; denormals in its robust traversal slowed a closed room's camera rays 3.5x on an
    AVX-512 Xeon), on the pool's threads and, for one thread, on the caller's, whose own
    setting comes back after."""
    from rt.embree import denormals

    if not denormals.X86:
        pytest.skip("MXCSR is x86-64's")
    flushed = lambda counter, bounds: int(denormals.mxcsr() & denormals.FTZ_DAZ == denormals.FTZ_DAZ)  # noqa: E731
    pos = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], np.float32)
    tri = np.array([[0, 1, 2]], np.int32)
    before = denormals.mxcsr()
    for threads in (3, 1):
        tracer = EmbreeTracer(pos, tri, threads=threads)
        assert tracer.run_parallel(flushed, 10) == threads
        seen = []
        tracer.map_chunks(100_000, lambda c, _, seen=seen: seen.append(flushed(None, None)))
        assert seen and all(seen)
        tracer.close()
        assert denormals.mxcsr() == before
