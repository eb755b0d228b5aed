"""The tracer interface and its Embree backend.

Passes only see `Tracer`: closest hits and occlusion on whole float32 ray arrays. A second
backend (a GPU one, say) implements the same two methods without touching the passes.
Embree is called from compiled code without the GIL (rt/embree/rtcore.py), so rays are split into
chunks and traced on a thread pool.
"""
from __future__ import annotations

import copy
import os
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np

from rt.embree import rtcore as embree
from rt.embree.blocks import block_bounds
from rt.embree.denormals import flush_denormals, flushed
from rt.embree.kernels import serial_kernels

INF = np.float32(1e30)


@dataclass
class Hits:
    t: np.ndarray  # (N,) float32, INF on a miss
    prim: np.ndarray  # (N,) int32, -1 on a miss
    u: np.ndarray  # (N,) float32 barycentric of vertex 1
    v: np.ndarray  # (N,) float32 barycentric of vertex 2

    @property
    def hit(self) -> np.ndarray:
        return self.prim >= 0


class Tracer:
    """What a pass may ask of a ray tracer."""

    rays_traced: int = 0

    def intersect(self, origins: np.ndarray, dirs: np.ndarray, tmax: np.ndarray | float | None = None) -> Hits:
        raise NotImplementedError

    def occluded(self, origins: np.ndarray, dirs: np.ndarray, tmax: np.ndarray | float) -> np.ndarray:
        """(N,) bool: something lies between origin and origin + tmax * dir."""
        raise NotImplementedError

    def intersect_image(self, origins: np.ndarray, dirs: np.ndarray, width: int, height: int) -> Hits:
        """intersect() of an image's rays (camera rays, in pixel order, row by row): a backend
        may trace neighbouring pixels together. This default traces them one by one."""
        return self.intersect(origins, dirs)

    def inline_scene(self) -> int:
        """An Embree scene handle with which compiled ray generators may trace their occlusion
        rays themselves as they make them (rt/embree/raygen.py), or 0: the caller traces them with
        occluded(). Whoever traces adds to rays_traced."""
        return 0

    def frame_target(self) -> tuple:
        """The tracing target (rtcore.target) of the whole-frame kernels that sample, trace and
        gather every pixel in one parallel call (run_parallel): the scene, and the ray log
        while rays are recorded. The caller adds the rays traced to rays_traced."""
        raise NotImplementedError

    def run_parallel(self, kernel, n: int, *args) -> int:
        """A whole-frame kernel over n points: kernel(counter, bounds, *args) is one worker, which
        takes blocks of points until none is left (blocks.block_bounds, next_block) and returns
        the rays it traced; the sum over workers is returned. This default runs one worker."""
        counter, bounds = np.zeros(1, np.int64), block_bounds(n, 1)
        return int(kernel(counter, bounds, *args))

    def map_chunks(self, n: int, work, key=None) -> None:
        """work(c, tracer) for slices c covering range(n); a backend may run them concurrently,
        each with a tracer to use from its own thread. key names the kind of work (a pass), so
        that a backend may size the slices from what the same work cost last time. This default
        runs one slice."""
        with serial_kernels():
            work(slice(0, n), self)


class RayLog:
    """Every ray a frame traces, for bench --perf to trace again with Embree alone: the
    whole-frame kernels append theirs to `rays` (rtcore.target), the chunked reference path its
    batches through Tracer.intersect / occluded. capacity: rays the kernels may log; more are
    counted but not kept (overflowed)."""

    def __init__(self, capacity: int):
        self.rays = np.empty((max(int(capacity), 1), embree.LOG_WIDTH), np.float32)
        self.count = np.zeros(1, np.int64)  # rays the kernels logged (atomically)
        # (kind, origins, directions, tmax) from the Python-level calls; camera rays ("primary")
        # also with their image's (width, height)
        self.batches: list = []

    def add(self, kind: str, o: np.ndarray, d: np.ndarray, tmax: np.ndarray, shape: tuple | None = None) -> None:
        self.batches.append((kind, o.copy(), d.copy(), tmax.copy()) + ((shape,) if shape is not None else ()))

    @property
    def overflowed(self) -> bool:
        return int(self.count[0]) > self.rays.shape[0]

    def all_batches(self) -> list:
        """Every logged ray as (kind, origins, directions, tmax) batches, kind "occluded" or
        "intersect" (Tracer.replay's input)."""
        logged = self.rays[:min(int(self.count[0]), self.rays.shape[0])]
        out = list(self.batches)
        for kind, code in (("occluded", 0.0), ("intersect", 1.0)):
            mine = logged[logged[:, 7] == code]
            if len(mine):
                out.append((kind, np.ascontiguousarray(mine[:, 0:3]), np.ascontiguousarray(mine[:, 3:6]),
                            np.ascontiguousarray(mine[:, 6])))
        return out

    def __len__(self) -> int:
        return sum(b[1].shape[0] for b in self.all_batches())


def default_threads() -> int:
    return max(1, len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1)


class EmbreeTracer(Tracer):
    # chunks_per_thread: 4 keeps threads busy when some chunks are cheap (sky rays) without
    # per-call overhead from tiny chunks (report/HISTORY.md has the measurements).
    def __init__(self, positions: np.ndarray, indices: np.ndarray, threads: int | None = None,
                 chunks_per_thread: int = 4, min_chunk: int = 4096, alpha=None):
        self.scene = embree.EmbreeScene(positions, indices, alpha)  # the BVH is built here
        self.handle = self.scene.handle
        self.threads = threads or default_threads()
        self.chunks_per_thread = chunks_per_thread
        self.min_chunk = min_chunk
        # map_chunks: each chunk's Python glue holds the GIL a little, so fewer, larger chunks
        # than for bare tracing
        self.chunks_per_worker = 1
        self.pool = self._pool(self.threads)
        self.rays_traced = 0
        self.recording: RayLog | None = None  # set to keep every ray traced (bench --perf replays them)
        self._costs: dict = {}  # map_chunks key -> its cost profile (cost_profile)

    @staticmethod
    def _pool(threads: int) -> ThreadPoolExecutor | None:
        """The tracing threads (none for one: the caller's), denormals flushed in each (rt/embree/denormals.py)."""
        return ThreadPoolExecutor(threads, initializer=flush_denormals) if threads > 1 else None

    def _chunk_count(self, n: int, per_thread: int | None = None) -> int:
        return max(1, min(self.threads * (per_thread or self.chunks_per_thread), n // self.min_chunk))

    def _chunks(self, n: int, per_thread: int | None = None) -> list[slice]:
        count = self._chunk_count(n, per_thread)
        bounds = [n * k // count for k in range(count + 1)]
        return [slice(a, b) for a, b in zip(bounds[:-1], bounds[1:], strict=True) if b > a]

    def _map(self, fn, n: int) -> None:
        chunks = self._chunks(n)
        if self.pool is None or len(chunks) == 1:
            with flushed():
                for c in chunks:
                    fn(c)
        else:
            list(self.pool.map(fn, chunks))

    def intersect(self, origins, dirs, tmax=None) -> Hits:
        o = np.ascontiguousarray(origins, np.float32)
        d = np.ascontiguousarray(dirs, np.float32)
        n = o.shape[0]
        dist = _distances(INF if tmax is None else tmax, n)
        t = np.empty(n, np.float32)
        prim = np.empty(n, np.int32)
        u = np.empty(n, np.float32)
        v = np.empty(n, np.float32)
        if self.recording is not None:
            self.recording.add("intersect", o, d, dist)
        if n:
            self._map(lambda c: embree.intersect(self.handle, o[c], d[c], dist[c], t[c], prim[c], u[c], v[c]), n)
        self.rays_traced += n
        return Hits(t, prim, u, v)

    def intersect_image(self, origins, dirs, width: int, height: int) -> Hits:
        """Packets of rtcore.TILE_W x TILE_H pixels (rtcore.intersect_tiles) on this tracer's threads."""
        o = np.ascontiguousarray(origins, np.float32)
        d = np.ascontiguousarray(dirs, np.float32)
        n = o.shape[0]
        t, prim = np.empty(n, np.float32), np.empty(n, np.int32)
        u, v = np.empty(n, np.float32), np.empty(n, np.float32)
        if self.recording is not None:  # the G-buffer's rays: replay_primary, not a pass's replay
            self.recording.add("primary", o, d, _distances(INF, n), (width, height))
        if n:
            self.run_parallel(embree.intersect_tiles, embree.tiles(width, height), self.handle, o, d, width, height,
                              t, prim, u, v)
        self.rays_traced += n
        return Hits(t, prim, u, v)

    def occluded(self, origins, dirs, tmax) -> np.ndarray:
        o = np.ascontiguousarray(origins, np.float32)
        d = np.ascontiguousarray(dirs, np.float32)
        n = o.shape[0]
        dist = _distances(tmax, n)
        out = np.empty(n, bool)
        if self.recording is not None:
            self.recording.add("occluded", o, d, dist)
        if n:
            self._map(lambda c: embree.occluded(self.handle, o[c], d[c], dist[c], out[c]), n)
        self.rays_traced += n
        return out

    def inline_scene(self) -> int:
        # only on a thread's own serial view (in a chunk), where tracing inline loses no
        # parallelism; and not while rays are recorded (bench --perf replays them)
        return self.handle if (self.pool is None and self.recording is None) else 0

    def frame_target(self) -> tuple:
        log = self.recording
        return embree.target(self.handle, *((log.rays, log.count) if log is not None else ()))

    def run_parallel(self, kernel, n: int, *args) -> int:
        """Tracer.run_parallel with a worker on each of this tracer's threads. The kernels are
        serial and release the GIL (nogil): threads here rather than numba's parallel loops,
        whose lowering compiled each kernel's whole body four times over (issue 44)."""
        workers = self.threads if self.pool is not None else 1
        counter, bounds = np.zeros(1, np.int64), block_bounds(n, workers)
        if workers == 1:
            with flushed():
                return int(kernel(counter, bounds, *args))
        running = [self.pool.submit(kernel, counter, bounds, *args) for _ in range(workers)]
        return sum(int(r.result()) for r in running)

    def serial_view(self) -> EmbreeTracer:
        """The same scene, traced on the calling thread (for code already running in a chunk)."""
        view = copy.copy(self)
        view.pool, view.threads, view.chunks_per_thread, view.rays_traced = None, 1, 1, 0
        return view

    def map_chunks(self, n: int, work, key=None) -> None:
        """work(c, tracer) for chunks c of range(n), on the tracing threads, each with a serial
        view of this tracer: a chunk's sampling, tracing and shading run on one thread, and
        chunks run side by side, with no whole-image phase between them. Chunks are runs of
        pixels in row order (nearby pixels trace nearby geometry), sized so that each should
        take the same time, from what each part of range(n) cost the last time work of this key
        ran (balanced_bounds)."""
        bounds = self.balanced_bounds(n, self._chunk_count(n, self.chunks_per_worker), self._costs.get(key))
        chunks = [slice(a, b) for a, b in zip(bounds[:-1], bounds[1:], strict=True) if b > a]
        todo = iter(chunks)  # next() on it is atomic under the GIL: workers take chunks as they free up
        seconds = {}
        views = []

        def run(_):
            # one task per thread, not per chunk: each task start costs a GIL hand-over, and with
            # 16 threads those queue up behind each other
            view = self.serial_view()
            with serial_kernels():
                for c in todo:  # CPU time, not wall time: waits for the GIL or a core are not the chunk's cost
                    t0 = time.thread_time()
                    work(c, view)
                    seconds[c.start] = time.thread_time() - t0
            views.append(view)

        workers = min(self.threads, len(chunks))
        if self.pool is None or workers <= 1:
            with flushed():
                run(0)
        else:
            list(self.pool.map(run, range(workers)))
        self.rays_traced += sum(v.rays_traced for v in views)
        if key is not None and len(chunks) > 1:
            self._costs[key] = self.cost_profile(self._costs.get(key), chunks, seconds, n)

    COST_BINS = 64  # resolution of a cost profile over range(n)

    @classmethod
    def cost_profile(cls, old, chunks, seconds: dict, n: int) -> np.ndarray:
        """Seconds per unit of range(n) in COST_BINS bins, each chunk's cost spread evenly over
        its bins and blended half and half with the profile before: bounds move from frame to
        frame, so the profile sharpens rather than jumping with each frame's few chunks."""
        centre = (np.arange(cls.COST_BINS) + 0.5) / cls.COST_BINS * n
        now = np.full(cls.COST_BINS, np.nan)
        for c in chunks:
            now[(centre >= c.start) & (centre < c.stop)] = seconds[c.start] / (c.stop - c.start) * n
        if old is None:
            return np.where(np.isnan(now), np.nanmean(now), now)
        return np.where(np.isnan(now), old, 0.5 * old + 0.5 * now)

    @classmethod
    def balanced_bounds(cls, n: int, count: int, profile=None) -> np.ndarray:
        """count + 1 chunk bounds over range(n): equal runs, or with a cost profile
        (cost_profile), equal shares of its cost (plus a tenth spread evenly, so that no part
        counts as free). The sky costs little and the floor much: equal runs of rows would leave
        threads idle."""
        if profile is None or count <= 1:
            return np.array([n * k // count for k in range(count + 1)])
        share = np.maximum(profile, 0.0) / max(float(np.maximum(profile, 0.0).sum()), 1e-12)
        share = 0.9 * share + 0.1 / len(share)
        cum = np.concatenate([[0.0], np.cumsum(share)])
        x = np.interp(np.arange(count + 1) / count * cum[-1], cum, np.linspace(0.0, 1.0, len(share) + 1))
        # no chunk under a third or over 3 x an equal run: each chunk also has a fixed cost
        size = np.diff(x)
        for _ in range(8):  # clip, renormalise, until both hold
            size = np.clip(size, 1.0 / (3 * count), 3.0 / count)
            size /= size.sum()
        x = np.concatenate([[0.0], np.cumsum(size)])
        bounds = np.maximum.accumulate(np.clip(np.round(x * n).astype(np.int64), 0, n))
        bounds[0], bounds[-1] = 0, n
        return bounds

    def replay(self, batches: list) -> float:
        """Trace recorded batches again, Embree alone: every occlusion ray, then every closest-hit
        ray, each kind as one parallel compiled loop on this tracer's threads (no sampling,
        shading or Python per chunk: the fastest this code can trace these rays, so the pass's
        physical limit). Returns the seconds spent."""
        runs = []
        for kind, fn, outputs in (("occluded", embree.occluded_blocks, (bool,)),
                                  ("intersect", embree.intersect_blocks, (np.float32, np.int32, np.float32,
                                                                             np.float32))):
            mine = [b for b in batches if b[0] == kind]
            if not mine:
                continue
            # gathered into one array of each before the clock starts, as a pass's scratch is
            o, d, t = (np.concatenate([b[k] for b in mine]) for k in (1, 2, 3))
            runs.append((fn, o, d, t, *(np.empty(o.shape[0], dt) for dt in outputs)))
        t0 = time.perf_counter()
        for fn, *args in runs:
            self.run_parallel(fn, args[0].shape[0], self.handle, *args)
        return time.perf_counter() - t0

    def replay_primary(self, batches: list) -> float:
        """Trace recorded camera rays again, Embree alone, as the G-buffer traces them (tiles
        of pixels as packets, intersect_image); returns the seconds spent."""
        runs = []
        for _, o, d, _, (width, height) in (b for b in batches if b[0] == "primary"):
            n = o.shape[0]
            runs.append((embree.tiles(width, height), o, d, width, height, np.empty(n, np.float32),
                         np.empty(n, np.int32), np.empty(n, np.float32), np.empty(n, np.float32)))
        t0 = time.perf_counter()
        for tiles, *args in runs:
            self.run_parallel(embree.intersect_tiles, tiles, self.handle, *args)
        return time.perf_counter() - t0

    def set_threads(self, threads: int) -> None:
        if self.pool is not None:
            self.pool.shutdown(wait=True)
        self.threads = threads
        self.pool = self._pool(threads)

    def close(self) -> None:
        if self.pool is not None:
            self.pool.shutdown(wait=False)
        self.scene.close()


def _distances(tmax, n: int) -> np.ndarray:
    """tmax as an (n,) float32 array, the caller's own if it already is one (Embree only reads it)."""
    if np.ndim(tmax) == 0:
        return np.full(n, np.float32(tmax), np.float32)
    return np.ascontiguousarray(tmax, np.float32)

