"""Process set-up for the Embree backend, done once by `init()` before its kernels load.

- numba's OpenMP threads would otherwise spin for a while after every parallel kernel,
  taking cores from the tracing threads that run next: OMP_WAIT_POLICY=PASSIVE, set before
  the first parallel kernel loads the OpenMP runtime.
- Compiled kernels are cached per version of this backend's sources: numba checks only the
  file of the function it loads, but a kernel carries the code of the kernels it calls from
  other modules, so after an update a cache keyed by one file could run old code. The cache
  directory is named after a hash of every source in rt/embree/ (and rt/layout.py, rt/keys.py)
  unless NUMBA_CACHE_DIR is set. numba reads it when a kernel is decorated, so init() runs before the kernel modules
  are imported (rt/backends.py, app/cli.py, tests/conftest.py).
- Freed memory is kept for reuse (memory.py).
- libembree4 is loaded so that compiled kernels resolve rtc* by name (rtcore.load)."""
from __future__ import annotations

import hashlib
import os
import pathlib
import sys

from core.cache import cache_root

_done = False


SHARED = ("layout.py", "keys.py")  # rt/ modules whose constants the kernels compile in


def sources(folder: pathlib.Path = pathlib.Path(__file__).parent) -> list[pathlib.Path]:
    """The files the kernels of this backend compile from: every *.py in the folder, and the
    shared rt/ modules beside it."""
    return sorted(folder.glob("*.py")) + [folder.parent / name for name in SHARED]


def cache_dir(folder: pathlib.Path = pathlib.Path(__file__).parent) -> pathlib.Path:
    """Where compiled kernels of these sources (sources(folder)) are cached."""
    digest = hashlib.sha1()
    for f in sources(folder):
        if f.exists():
            digest.update(f.name.encode() + b"\0" + f.read_bytes())
    return cache_root() / "numba" / digest.hexdigest()[:16]


def init() -> None:
    """Set the process up for the Embree backend (idempotent)."""
    global _done
    if _done:
        return
    _done = True
    os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")
    from rt.embree.memory import keep_freed_memory

    keep_freed_memory()
    if "NUMBA_CACHE_DIR" not in os.environ:
        os.environ["NUMBA_CACHE_DIR"] = str(cache_dir())
        if "numba" in sys.modules:  # numba read its settings already
            import numba

            numba.config.CACHE_DIR = os.environ["NUMBA_CACHE_DIR"]
    from rt.embree import rtcore

    rtcore.load()
