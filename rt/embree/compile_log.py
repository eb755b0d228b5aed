"""Which passes this version of the backend has compiled kernels for, and how long compiling them
took here last time, so that a first frame says what it waits for and for about how long.

- Per version: `passes.json` in the kernel cache folder (process.cache_dir, one per version of
  the sources) lists the passes whose first frame compiled, or found compiled, every kernel, for
  the checkout whose files' paths and times it names (numba recompiles for another).
- Across versions: `compile_times.json` beside the cache folders keeps each pass's last
  measured compile time on this machine (a new version compiles about as long as the last).

watch() measures: numba's compile events tell whether a frame compiled anything, so a time is
recorded only for a frame that did. Writers take a file lock (warmup runs several processes)."""
from __future__ import annotations

import contextlib
import fcntl
import hashlib
import json
import os
import pathlib
import time


def _cache_folder() -> pathlib.Path:
    from rt.embree.process import cache_dir

    return pathlib.Path(os.environ.get("NUMBA_CACHE_DIR") or cache_dir())


def _version_file() -> pathlib.Path:
    return _cache_folder() / "passes.json"


def _times_file() -> pathlib.Path:
    return _cache_folder().parent / "compile_times.json"


def _read(path: pathlib.Path) -> dict:
    try:
        data = json.loads(path.read_text())
    except (OSError, ValueError):
        return {}
    return data if isinstance(data, dict) else {}


def _stamp() -> str:
    """The sources as numba's cache index sees them: it keeps a kernel only while its file has the
    same path, time and size, so another checkout of the same version compiles again."""
    from rt.embree.process import sources

    digest = hashlib.sha1()
    for f in sources():
        with contextlib.suppress(OSError):
            st = f.stat()
            digest.update(f"{f.resolve()}:{st.st_mtime_ns}:{st.st_size}\n".encode())
    return digest.hexdigest()[:16]


def compiled_keys() -> set[str]:
    """The passes whose kernels this version has compiled (cached) for this checkout."""
    stamp = _stamp()
    return {name for name, entry in _read(_version_file()).items()
            if isinstance(entry, dict) and entry.get("stamp") == stamp}


def compiled(name: str) -> bool:
    """Whether this version's kernels for pass `name` are compiled (cached) for this checkout."""
    return name in compiled_keys()


def last_seconds(name: str) -> float | None:
    """How long compiling pass `name`'s kernels took here last time (any version), if known."""
    value = _read(_times_file()).get(name)
    return float(value) if isinstance(value, (int, float)) else None


def record(name: str, seconds: float | None) -> None:
    """Pass `name`'s kernels are compiled for this version; seconds: what compiling took (None:
    they were compiled already, nothing was measured)."""
    folder = _cache_folder()
    try:
        folder.mkdir(parents=True, exist_ok=True)
        with open(folder.parent / ".compile_log.lock", "w") as lock:
            fcntl.flock(lock, fcntl.LOCK_EX)
            _update(_version_file(), name, {"stamp": _stamp(),
                                            "seconds": None if seconds is None else round(seconds, 1)})
            if seconds is not None:
                _update(_times_file(), name, round(seconds, 1))
    except OSError:  # a read-only cache: nothing to remember, nothing breaks
        pass


def _update(path: pathlib.Path, key: str, value) -> None:
    data = _read(path)
    data[key] = value
    tmp = path.with_suffix(f".{os.getpid()}.tmp")
    tmp.write_text(json.dumps(data, indent=1, sort_keys=True))
    tmp.replace(path)


def notices(names) -> list[str]:
    """What a first frame of passes `names` will wait for: a line for each whose kernels are not
    compiled yet."""
    done, lines = compiled_keys(), []
    for name in names:
        if name in done:
            continue
        last = last_seconds(name)
        # a time only where one was measured on this machine (the frame's own line says how long it took)
        took = f"took {last:.0f} s here last time" if last is not None else "not yet timed on this machine"
        lines.append(f"compiling the {name} kernels (once per version; {took}; `rtlab warmup` compiles every "
                     f"pass ahead)")
    return lines


def notice(name: str) -> str | None:
    """What a first frame of pass `name` will wait for, or None if its kernels are compiled."""
    return next(iter(notices([name])), None)


@contextlib.contextmanager
def watch(names):
    """Around a first frame of passes `names`: records them compiled, with the time taken if the
    frame compiled any kernel. Yields an object whose `compiles` counts numba's compilations."""
    from numba.core import event

    class Counter(event.Listener):  # compilations of this backend's kernels while installed
        compiles = 0

        def on_start(self, ev):
            func = getattr(ev.data.get("dispatcher"), "py_func", None)
            if str(getattr(func, "__module__", "")).startswith("rt.embree."):
                self.compiles += 1

        def on_end(self, ev):
            pass

    counter = Counter()
    event.register("numba:compile", counter)
    t0 = time.perf_counter()
    try:
        yield counter
    finally:
        event.unregister("numba:compile", counter)
    elapsed = time.perf_counter() - t0
    done = compiled_keys() if names else set()
    for name in names:
        if name not in done:
            record(name, elapsed if counter.compiles else None)
