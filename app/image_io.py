"""Output files, written atomically (temporary file, then rename) so an interrupted run
never leaves a half-written file that looks complete."""
from __future__ import annotations

import os
import tempfile
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from core.errors import UserError


@contextmanager
def atomic_path(path: str | Path):
    """Yields a temporary path next to `path`; renames it over `path` on success."""
    path = Path(path)
    folder = path.parent if str(path.parent) else Path(".")
    if not folder.is_dir():
        raise UserError(f"cannot write {path}: folder {folder} does not exist")
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".part", dir=folder)
    except OSError as e:
        raise UserError(f"cannot write {path}: {e.strerror}") from None
    os.close(fd)
    try:
        yield Path(tmp)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes 0600 files; outputs get the usual mode
        os.replace(tmp, path)
    except OSError as e:
        raise UserError(f"cannot write {path}: {e.strerror}") from None
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


def check_output(path, suffix: str, what: str) -> Path:
    """Refuse an output path that cannot be written, before any work is done: the wrong
    suffix, a folder, a missing or unwritable parent folder, a name too long."""
    path = Path(path)
    if path.suffix.lower() != suffix:
        raise UserError(f"{str(path)[:200]}: {what} are written as {suffix}")
    folder = path.parent if str(path.parent) else Path(".")
    try:
        if path.is_dir():
            raise UserError(f"cannot write {str(path)[:200]}: it is a folder")
        if not folder.is_dir():
            raise UserError(f"cannot write {str(path)[:200]}: folder {str(folder)[:200]} does not exist")
        if path.exists() and not path.is_file():
            raise UserError(f"cannot write {str(path)[:200]}: not a regular file")
    except OSError as e:  # a name too long, a loop of links...
        raise UserError(f"cannot write {str(path)[:200]}: {e.strerror}") from None
    except ValueError as e:  # a NUL in the name
        raise UserError(f"cannot write {str(path)[:200]!r}: {e}") from None
    if len(path.name.encode("utf-8", "replace")) > 240:  # room for atomic_path's temporary name
        raise UserError(f"cannot write {str(path)[:200]}...: file name too long")
    if not os.access(folder, os.W_OK | os.X_OK):
        raise UserError(f"cannot write {str(path)[:200]}: folder {str(folder)[:200]} is not writable")
    return path


def write_png(path, rgb: np.ndarray) -> None:
    from PIL import Image

    check_output(path, ".png", "screenshots")
    with atomic_path(path) as tmp:
        Image.fromarray(np.ascontiguousarray(rgb, np.uint8)).save(tmp, format="PNG")


def read_png(path) -> np.ndarray:
    """An 8-bit RGB image from a PNG file (as write_png wrote it)."""
    from PIL import Image

    with Image.open(path) as im:
        return np.asarray(im.convert("RGB"))


def write_npy(path, array: np.ndarray) -> None:
    check_output(path, ".npy", "raw images")
    with atomic_path(path) as tmp:
        with open(tmp, "wb") as f:
            np.save(f, np.ascontiguousarray(array, np.float32))


def write_text(path, text: str) -> None:
    with atomic_path(path) as tmp:
        Path(tmp).write_text(text)
