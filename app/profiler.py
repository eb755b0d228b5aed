"""Per-pass timing shared by every pass: GPU time for raster, CPU time for ray tracing."""
from __future__ import annotations

import time
from collections import defaultdict, deque
from contextlib import contextmanager


class Profiler:
    """deferred: GPU times are read a frame late (collect(), or the pass's next use), so reading
    them never waits for the GPU (the viewer); otherwise right away (shot, bench)."""

    def __init__(self, history: int = 120, deferred: bool = False):
        self.history = history
        self.deferred = deferred
        self._pending: dict = {}  # (context, pass) -> (query, pass) issued, not read yet (collect)
        self.samples: dict[str, deque] = defaultdict(lambda: deque(maxlen=self.history))
        self.kind: dict[str, str] = {}
        self.frame: dict[str, float] = {}
        self._queries: dict = {}
        self.counters: dict[str, float] = {}
        # the last frame that was finished (end_frame): what the panel shows while the next one
        # is still being traced, and only the passes that frame ran
        self.finished: dict[str, float] = {}
        self.finished_counters: dict[str, float] = {}

    def record(self, name: str, ms: float, kind: str = "cpu") -> None:
        self.samples[name].append(ms)
        self.kind[name] = kind
        self.frame[name] = self.frame.get(name, 0.0) + ms

    @contextmanager
    def cpu(self, name: str):
        t0 = time.perf_counter()
        try:
            yield
        finally:
            self.record(name, (time.perf_counter() - t0) * 1e3, "cpu")

    @contextmanager
    def gpu(self, ctx, name: str):
        """GPU time of the GL commands issued inside (a timer query). Not deferred: waits for the
        result. Deferred: read later, by collect() or at the pass's next use."""
        if self.deferred:
            with self._deferred(ctx, name):
                yield
            return
        q = self._queries.get((id(ctx), name))
        if q is None:
            q = self._queries[(id(ctx), name)] = ctx.query(time=True)
        t0 = time.perf_counter()
        with q:
            yield
        ns = q.elapsed
        if ns >= 2**32 - 1:  # moderngl reads the query as 32 bits: past ~4.3 s it saturates
            ns = (time.perf_counter() - t0) * 1e9  # the wall time (elapsed waited for the GPU)
        self.record(name, ns / 1e6, "gpu")

    @contextmanager
    def _deferred(self, ctx, name: str):
        key = (id(ctx), name)
        q = self._queries.get(key)
        if q is None:
            q = self._queries[key] = ctx.query(time=True)
        if key in self._pending:  # the last use's result, read before its query is reused
            self._read(key)
        with q:
            yield
        self._pending[key] = (q, name)

    def collect(self) -> None:
        """Deferred mode: read the GPU times still pending (the viewer calls this once per UI
        frame, a frame after they were issued, when the GPU is done with them) into the samples
        and the last finished frame's times."""
        for key in list(self._pending):
            self._read(key)

    def _read(self, key) -> None:
        q, name = self._pending.pop(key)
        ns = q.elapsed
        if 0 <= ns < 2**32 - 1:  # a saturated 32-bit read is never shown
            ms = ns / 1e6
            self.samples[name].append(ms)
            self.kind[name] = "gpu"
            self.finished[name] = ms

    def begin_frame(self) -> None:
        self.frame = {}
        self.counters = {}

    def end_frame(self) -> None:
        self.finished, self.finished_counters = dict(self.frame), dict(self.counters)

    def count(self, name: str, n: float) -> None:
        self.counters[name] = self.counters.get(name, 0) + n

    def last(self, name: str) -> float:
        s = self.samples.get(name)
        return s[-1] if s else 0.0

    def average(self, name: str) -> float:
        s = self.samples.get(name)
        return sum(s) / len(s) if s else 0.0

    def names(self) -> list[str]:
        return list(self.samples)
