"""Validation of values read from untrusted scene files: type, shape, range and cross-
references are checked before use, and each failure is one UserError naming the file and the
value ("scene.gltf: materials[2].emissiveFactor: expected 3 numbers, got 4")."""
from __future__ import annotations

import math
import os
import stat
from pathlib import Path

from core.errors import UserError
from scenes.cache import note_read

F32_MAX = 3.4028234663852886e38
INT32_MAX = 2**31 - 1
# the most elements (vertices, indices, texels...) one array of a scene file may declare
MAX_ELEMENTS = 2**31 - 1
# the most pixels of one texture image; larger images are refused before they are decoded
MAX_IMAGE_PIXELS = 8192 * 8192


class Checker:
    """Checks values of one file; `name` starts every message."""

    def __init__(self, name: str):
        self.name = name

    def fail(self, what: str, problem: str):
        raise UserError(f"{self.name}: {what}: {problem}")

    def mapping(self, value, what: str) -> dict:
        if not isinstance(value, dict):
            self.fail(what, f"expected an object, got {_kind(value)}")
        return value

    def array(self, value, what: str, max_len: int = MAX_ELEMENTS) -> list:
        if not isinstance(value, list):
            self.fail(what, f"expected an array, got {_kind(value)}")
        if len(value) > max_len:
            self.fail(what, f"{len(value)} entries (at most {max_len})")
        return value

    def objects(self, value, what: str) -> list:
        """An array of objects."""
        items = self.array(value, what)
        for k, item in enumerate(items):
            self.mapping(item, f"{what}[{k}]")
        return items

    def boolean(self, value, what: str) -> bool:
        if not isinstance(value, bool):
            self.fail(what, f"expected true or false, got {_kind(value)}")
        return value

    def string(self, value, what: str) -> str:
        if not isinstance(value, str):
            self.fail(what, f"expected a string, got {_kind(value)}")
        return value

    def integer(self, value, what: str, lo: int = 0, hi: int = INT32_MAX) -> int:
        if isinstance(value, bool) or not isinstance(value, int):
            self.fail(what, f"expected an integer, got {_kind(value)}")
        if not lo <= value <= hi:
            self.fail(what, f"{_short(value)} is out of range {lo}..{hi}")
        return value

    def index(self, value, count: int, what: str) -> int:
        """An index into an array of `count` entries."""
        if count == 0:
            self.integer(value, what)
            self.fail(what, f"refers to entry {_short(value)} of an empty array")
        return self.integer(value, what, 0, count - 1)

    def number(self, value, what: str, lo: float = -F32_MAX, hi: float = F32_MAX) -> float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            self.fail(what, f"expected a number, got {_kind(value)}")
        try:
            v = float(value)
        except OverflowError:
            v = math.inf
        if not math.isfinite(v):
            self.fail(what, f"{_short(value)} is not a finite number")
        if not lo <= v <= hi:
            self.fail(what, f"{_short(value)} is out of range {lo:g}..{hi:g}")
        return v

    def vector(self, value, n: int, what: str, lo: float = -F32_MAX, hi: float = F32_MAX) -> tuple:
        items = self.array(value, what, max_len=1 << 20)
        if len(items) != n:
            self.fail(what, f"expected {n} numbers, got {len(items)}")
        return tuple(self.number(x, f"{what}[{k}]", lo, hi) for k, x in enumerate(items))


def _kind(value) -> str:
    if value is None:
        return "null"
    if isinstance(value, bool):
        return "a boolean"
    if isinstance(value, (int, float)):
        return f"the number {_short(value)}"
    if isinstance(value, str):
        return f"the string {_short(value)!r}" if len(value) < 40 else "a string"
    if isinstance(value, list):
        return f"an array of {len(value)}"
    if isinstance(value, dict):
        return "an object"
    return type(value).__name__


def _short(value) -> str:
    """A number as text, even one too long for Python's int-to-string limit."""
    if isinstance(value, int) and not isinstance(value, bool) and abs(value) > 10**30:
        return f"an integer of {value.bit_length()} bits"
    text = str(value)
    return text if len(text) <= 40 else text[:37] + "..."


def open_regular(path: Path, what: str):
    """Opens `path` for reading only if it is a regular file (not a FIFO, device or folder),
    without blocking; the error names `what`."""
    try:
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_NOCTTY", 0))
    except OSError as e:
        raise UserError(f"{what}: cannot read {path.name[:80]!r}: {e.strerror}") from None
    try:
        if not stat.S_ISREG(os.fstat(fd).st_mode):
            raise UserError(f"{what}: {path.name[:80]!r} is not a regular file")
        os.set_blocking(fd, True)
        return os.fdopen(fd, "rb")
    except BaseException:
        os.close(fd)
        raise


def read_regular(path: Path, what: str, limit: int | None = None) -> bytes:
    """The bytes of a regular file (open_regular), refusing files over `limit` bytes."""
    note_read(path)  # what a cached scene was made from (scenes/cache.py)
    with open_regular(path, what) as f:
        size = os.fstat(f.fileno()).st_size
        if limit is not None and size > limit:
            raise UserError(f"{what}: {path.name[:80]!r} is {size:,} bytes, more than the {limit:,} allowed")
        try:
            return f.read()
        except OSError as e:
            raise UserError(f"{what}: cannot read {path.name[:80]!r}: {e.strerror}") from None
