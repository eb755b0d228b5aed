"""Helpers shared by the file loaders."""
from __future__ import annotations

import io
import warnings
from pathlib import Path

import numpy as np

from core.errors import UserError
from scenes.loaders.checks import MAX_IMAGE_PIXELS


def safe_child(scene_file: Path, relative: str) -> Path:
    """Resolve a path referenced by a scene file; refuse anything outside the scene's folder."""
    folder = scene_file.resolve().parent
    if "\0" in relative:
        raise UserError(f"{scene_file.name}: refusing a file name with a NUL character")
    if len(relative) > 4096 or any(len(part.encode("utf-8", "replace")) > 255 for part in relative.split("/")):
        raise UserError(f"{scene_file.name}: refusing {relative[:60]!r}...: file name too long")
    rel = Path(relative)
    if rel.is_absolute() or relative.startswith(("/", "\\")) or "://" in relative:
        raise UserError(f"{scene_file.name}: refusing {relative[:80]!r}: referenced files must lie in the scene's "
                        "folder")
    target = (folder / rel).resolve()
    if folder not in target.parents and target != folder:
        raise UserError(f"{scene_file.name}: refusing {relative[:80]!r}: it points outside the scene's folder")
    return target


def srgb_to_linear(c: np.ndarray) -> np.ndarray:
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4).astype(np.float32)


MAX_TEXTURE_SIDE = 1024  # textures are downsampled to this at load: what the GL texture arrays hold too


def decode_image(data: bytes, what: str, srgb: bool = True, alpha: bool = False) -> np.ndarray | None:
    """Image bytes -> H x W x 3 (or 4 with alpha) float32 in [0, 1], colour channels decoded
    from sRGB when `srgb` (alpha never is), downsampled to at most MAX_TEXTURE_SIDE; or None
    (with a warning) if the image cannot be decoded or is larger than MAX_IMAGE_PIXELS or the
    free memory: the header's size is checked before any pixel is decoded."""
    from PIL import Image

    try:
        with warnings.catch_warnings():  # Pillow's own bomb warning: the size check below says it better
            warnings.simplefilter("ignore", Image.DecompressionBombWarning)
            img = Image.open(io.BytesIO(data))
        with img:
            w, h = img.size
            need = w * h * 48  # decoded bytes, float copies and the sRGB conversion's temporaries
            if w * h > MAX_IMAGE_PIXELS or need > available_memory() * 0.5:
                warnings.warn(f"{what}: a {w}x{h} image is larger than rtlab decodes ({MAX_IMAGE_PIXELS:,} "
                              "pixels); using the base colour", stacklevel=2)
                return None
            img = img.convert("RGBA" if alpha else "RGB")
            if max(w, h) > MAX_TEXTURE_SIDE:
                scale = MAX_TEXTURE_SIDE / max(w, h)
                img = img.resize((max(1, round(w * scale)), max(1, round(h * scale))), Image.BOX)
            pixels = np.asarray(img, np.float32) / 255.0
    except Exception as e:  # noqa: BLE001 - Pillow's decoders raise many kinds of error for broken files
        warnings.warn(f"{what}: cannot decode image ({type(e).__name__}: {str(e)[:120]}); using the base colour",
                      stacklevel=2)
        return None
    if srgb:
        pixels[..., :3] = srgb_to_linear(pixels[..., :3])
    return pixels


def compute_normals(positions: np.ndarray, tris: np.ndarray) -> np.ndarray:
    """Area-weighted vertex normals, for files that carry none."""
    p = positions.astype(np.float64)
    tris = np.asarray(tris, np.int64)
    fn = np.cross(p[tris[:, 1]] - p[tris[:, 0]], p[tris[:, 2]] - p[tris[:, 0]])
    vn = np.zeros_like(p)
    for k in range(3):
        np.add.at(vn, tris[:, k], fn)
    return vn.astype(np.float32)


# Bytes per triangle and per vertex across every copy rtlab makes: the scene model, the GPU
# buffers, the tracer's shading arrays and Embree's BVH. Measured without GL: 0.96 GB peak for
# park:5 (2.25M triangles, 4.5M vertices); these constants allow about twice that.
BYTES_PER_TRIANGLE = 600
BYTES_PER_VERTEX = 160


def available_memory() -> int:
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    return 1 << 62  # unknown: do not refuse


def check_memory(triangles: int, vertices: int, what: str) -> None:
    """Refuse a scene that would not fit in memory, before anything large is allocated."""
    need = triangles * BYTES_PER_TRIANGLE + vertices * BYTES_PER_VERTEX
    have = available_memory()
    if need > have * 0.8:
        raise UserError(f"{what}: too large for this machine: {triangles:,} triangles need about "
                        f"{need / 2**30:.1f} GiB, {have / 2**30:.1f} GiB is available")
