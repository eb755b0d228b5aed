"""Environment maps: equirectangular images of linear radiance, Radiance .hdr (RGBE, decoded by
imagecodecs) and OpenEXR .exr (the OpenEXR project's own binding), for option env=FILE."""
from __future__ import annotations

import os
import warnings
from pathlib import Path

import numpy as np

from core.errors import UserError
from scenes.loaders.checks import open_regular, read_regular
from scenes.model import Environment

SUFFIXES = (".hdr", ".exr")
MAX_TEXELS = 16384 * 8192
MAX_BYTES = 2 << 30
_CACHE: dict[tuple, np.ndarray] = {}  # (path, mtime, size): pixels, so a frame's env option reads no file


def is_map_spec(text: str) -> bool:
    return text.strip().lower().endswith(SUFFIXES)


def parse_env(text: str) -> Environment:
    """Option env's value: a map file (.hdr, .exr) or a named environment / R,G,B."""
    if is_map_spec(text):
        path = Path(os.path.expanduser(text.strip()))
        return Environment("map", pixels=read_envmap(path), source=str(path))
    return Environment.parse(text)


def read_envmap(path: Path) -> np.ndarray:
    """(H, W, 3) float32 linear radiance of a .hdr or .exr file; UserError with one line for a
    missing, unreadable or corrupt file."""
    what = "env"
    try:
        st = path.stat()
    except OSError as e:
        raise UserError(f"{what}: cannot read {path.name[:80]!r}: {e.strerror}") from None
    key = (str(path.resolve()), st.st_mtime_ns, st.st_size)
    if key not in _CACHE:
        pixels = _read_exr(path, what) if path.suffix.lower() == ".exr" else _read_hdr(path, what)
        _CACHE.clear()  # one map at a time: they can be hundreds of MB
        _CACHE[key] = _checked(pixels, path, what)
    return _CACHE[key]


def _read_hdr(path: Path, what: str) -> np.ndarray:
    import imagecodecs

    data = read_regular(path, what, MAX_BYTES)
    try:
        return np.asarray(imagecodecs.rgbe_decode(data))
    except Exception as e:  # imagecodecs' RgbeError, ValueError: a corrupt or truncated file
        raise UserError(f"{what}: {path.name[:80]!r} is not a readable Radiance .hdr image ({str(e)[:80]})") from None


def _read_exr(path: Path, what: str) -> np.ndarray:
    import OpenEXR

    with open_regular(path, what):  # a regular file, not a FIFO or a device, before the library opens it
        pass
    try:
        with OpenEXR.File(str(path)) as f:
            channels = f.channels()
            if "RGB" in channels or "RGBA" in channels:
                pixels = np.asarray(channels.get("RGB", channels.get("RGBA")).pixels)[..., :3]
            elif {"R", "G", "B"} <= channels.keys():
                pixels = np.stack([np.asarray(channels[c].pixels) for c in "RGB"], -1)
            elif "Y" in channels:
                pixels = np.repeat(np.asarray(channels["Y"].pixels)[..., None], 3, -1)
            else:
                raise UserError(f"{what}: {path.name[:80]!r} has no R, G, B or Y channels "
                                f"(it has {', '.join(sorted(channels))[:80]})")
    except UserError:
        raise
    except Exception as e:  # the library's RuntimeError for a corrupt file
        raise UserError(f"{what}: {path.name[:80]!r} is not a readable OpenEXR image ({str(e)[:80]})") from None
    return pixels


def _checked(pixels: np.ndarray, path: Path, what: str) -> np.ndarray:
    if pixels.ndim != 3 or pixels.shape[2] != 3 or pixels.shape[0] < 1 or pixels.shape[1] < 1:
        raise UserError(f"{what}: {path.name[:80]!r} is not an RGB image (shape {pixels.shape})")
    if pixels.shape[0] * pixels.shape[1] > MAX_TEXELS:
        raise UserError(f"{what}: {path.name[:80]!r} has {pixels.shape[1]} x {pixels.shape[0]} texels, more than "
                        f"the {MAX_TEXELS:,} allowed")
    pixels = np.ascontiguousarray(pixels, np.float32)
    if not np.isfinite(pixels).all():
        raise UserError(f"{what}: {path.name[:80]!r} holds values that are not finite numbers")
    if (pixels < 0).any():
        warnings.warn(f"{path.name[:80]}: negative radiance in the map read as 0", stacklevel=3)
        pixels = np.maximum(pixels, 0)
    return pixels
