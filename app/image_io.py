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


def write_png(path, rgb: np.ndarray) -> None:
    from PIL import Image

    if Path(path).suffix.lower() != ".png":
        raise UserError(f"{path}: screenshots are written as .png")
    with atomic_path(path) as tmp:
        Image.fromarray(np.ascontiguousarray(rgb, np.uint8)).save(tmp, format="PNG")


def write_npy(path, array: np.ndarray) -> None:
    if Path(path).suffix.lower() != ".npy":
        raise UserError(f"{path}: raw images are written as .npy")
    with atomic_path(path) as tmp:
        with open(tmp, "wb") as f:
            np.save(f, np.ascontiguousarray(array, np.float32))


def write_text(path, text: str) -> None:
    with atomic_path(path) as tmp:
        Path(tmp).write_text(text)
