"""Big scene files loaded once: the Scene a reader made, kept on disk under
~/.cache/rtlab/scenes/ (XDG_CACHE_HOME), keyed by the file's content and the readers' source, so
that opening the same file again reads one binary file instead of parsing, decoding and checking
it again. The other files a reader read (a glTF's buffers and images, an OBJ's materials) are
recorded with their size and time: a changed, added or removed one makes the entry stale. The
reader's warnings are kept with the scene and said again. RTLAB_SCENE_CACHE=0 turns it off."""
from __future__ import annotations

import contextlib
import functools
import hashlib
import os
import pickle
import warnings
from pathlib import Path

from core.cache import cache_root
from scenes.progress import stage

MIN_BYTES = 8 << 20  # smaller files read in well under a second: not cached
MAX_ENTRIES = 8  # the least recently used beyond these are removed
FORMAT = 1

_reads: list[Path] | None = None  # while a reader runs under record_reads(): the files it asked for


def note_read(path: Path) -> None:
    """Called by the readers' one way to read a file (loaders.checks.read_regular)."""
    if _reads is not None:
        _reads.append(Path(path))


@contextlib.contextmanager
def record_reads():
    global _reads
    outer, _reads = _reads, []
    try:
        yield _reads
    finally:
        _reads = outer


def cache_dir() -> Path:
    """~/.cache/rtlab/scenes, or $RTLAB_SCENE_CACHE_DIR (bench --load measures cold opens in its own)."""
    return Path(os.environ["RTLAB_SCENE_CACHE_DIR"]) if os.environ.get("RTLAB_SCENE_CACHE_DIR") else \
        cache_root() / "scenes"


@functools.lru_cache(maxsize=1)
def _sources_digest() -> bytes:
    """The readers' and the scene model's source: another version reads files anew."""
    h = hashlib.blake2b(digest_size=16)
    root = Path(__file__).resolve().parent
    for f in sorted([root / "model.py", *(root / "loaders").glob("*.py")]):
        h.update(f.name.encode())
        h.update(f.read_bytes())
    return h.digest()


def _stamp(path: Path):
    try:
        st = path.stat()
    except OSError:
        return None
    return st.st_size, st.st_mtime_ns


def load_cached(path: Path, read):
    """read(path) -> Scene, through the cache where the file is big enough and the cache on."""
    try:
        size = path.stat().st_size
    except OSError:
        return read(path)
    if os.environ.get("RTLAB_SCENE_CACHE", "1") == "0" or size < MIN_BYTES:
        return read(path)
    stage("looking in the scene cache")
    h = hashlib.blake2b(digest_size=20)
    h.update(_sources_digest() + bytes([FORMAT]))
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 24), b""):
            h.update(block)
    entry = cache_dir() / f"{h.hexdigest()}.pickle"
    found = _read_entry(entry)
    if found is not None:
        stage("read from the scene cache")
        for message in found["warnings"]:
            warnings.warn(message, stacklevel=3)
        return found["scene"]
    with record_reads() as reads, warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        scene = read(path)
    messages = list(dict.fromkeys(str(w.message) for w in seen))
    for message in messages:
        warnings.warn(message, stacklevel=3)
    others = {p.resolve(): _stamp(p) for p in reads if p.resolve() != path.resolve()}
    _write_entry(entry, {"scene": scene, "warnings": messages, "others": others})
    return scene


def _read_entry(entry: Path):
    """The cached record, or None where there is none, it is unreadable, or a file it was made
    from changed."""
    try:
        with open(entry, "rb") as f:
            record = pickle.load(f)
        if not all(_stamp(p) == stamp for p, stamp in record["others"].items()):
            return None
        os.utime(entry)  # recently used
        return record
    except Exception:  # noqa: BLE001 - missing, truncated or from another version: read the file again
        return None


def _write_entry(entry: Path, record: dict) -> None:
    """Written whole or not at all (a temporary file renamed); a full disk only costs the cache."""
    tmp = entry.with_suffix(f".{os.getpid()}.tmp")
    try:
        entry.parent.mkdir(parents=True, exist_ok=True)
        with open(tmp, "wb") as f:
            pickle.dump(record, f, protocol=pickle.HIGHEST_PROTOCOL)
        os.replace(tmp, entry)
        entries = sorted(entry.parent.glob("*.pickle"), key=lambda p: p.stat().st_mtime, reverse=True)
        for old in entries[MAX_ENTRIES:]:
            old.unlink(missing_ok=True)
    except OSError:
        with contextlib.suppress(OSError):
            tmp.unlink(missing_ok=True)
