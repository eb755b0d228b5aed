"""CPU ray tracing on Embree: tracer, sampling, hit shading and one module per pass.

numba's OpenMP threads would otherwise spin for a while after every parallel kernel, taking
cores from the tracing threads that run next (measured: ~1.5x slower passes on 2 cores).
This must be set before the first parallel kernel loads the OpenMP runtime.

Compiled kernels are cached per version of this package's sources: numba checks only the
file of the function it loads, but a kernel carries the code of the kernels it calls from
other modules (rt/ao.py's frame kernel holds rt/raygen.py's generators), so after an update a
cache keyed by one file could run old code. The cache directory is named after a hash of
every source in rt/ unless NUMBA_CACHE_DIR is set.

Freed memory is kept for reuse (rt/memory.py): otherwise each frame's scratch comes back as
fresh pages, a page fault each."""
import hashlib
import os
import pathlib

os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")

from rt.memory import keep_freed_memory  # noqa: E402

keep_freed_memory()


def cache_dir(sources: pathlib.Path = pathlib.Path(__file__).parent) -> pathlib.Path:
    """Where compiled kernels of these sources (every *.py in the folder) are cached."""
    digest = hashlib.sha1()
    for f in sorted(sources.glob("*.py")):
        digest.update(f.name.encode() + b"\0" + f.read_bytes())
    base = pathlib.Path(os.environ.get("XDG_CACHE_HOME") or pathlib.Path.home() / ".cache")
    return base / "rtlab" / "numba" / digest.hexdigest()[:16]


if "NUMBA_CACHE_DIR" not in os.environ:
    os.environ["NUMBA_CACHE_DIR"] = str(cache_dir())
    import sys

    if "numba" in sys.modules:  # numba read its settings already
        import numba

        numba.config.CACHE_DIR = os.environ["NUMBA_CACHE_DIR"]
