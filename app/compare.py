"""Side-by-side comparison of two passes of the same camera and options (`--compare`): the
left pass up to the divider at a fraction of the width, the right one after it, each labelled
with its name and time; `--compare diff` puts the FLIP error map of the pass against the
reference path tracer on the right (app/quality.py's FLIP, the magma map: black = identical)."""
from __future__ import annotations

import numpy as np

from core.errors import UserError

DIFF = "diff"
REFERENCE_FRAMES = 64  # frames of the reference that `--compare diff` measures against


def check_compare(left: str, right: str | None, split: float) -> None:
    from app.passes import check_pass

    if right is None:
        return
    if right != DIFF:
        check_pass(right)
    if not 0.0 <= split <= 1.0:
        raise UserError(f"--split must be within 0..1, got {split}")


def flip_map(reference: np.ndarray, test: np.ndarray) -> tuple[np.ndarray, float]:
    """(H x W x 3 uint8 magma-coloured FLIP error map, mean FLIP) of two sRGB uint8 images."""
    import flip_evaluator as flip

    ref = np.ascontiguousarray(reference.astype(np.float32) / 255.0)
    tst = np.ascontiguousarray(test.astype(np.float32) / 255.0)
    error, mean, _ = flip.evaluate(ref, tst, "LDR", applyMagma=True)
    return np.clip(np.asarray(error)[..., :3] * 255.0 + 0.5, 0, 255).astype(np.uint8), float(mean)


def compose(left: np.ndarray, right: np.ndarray, split: float, labels: tuple[str, str]) -> np.ndarray:
    """The two H x W x 3 uint8 images side by side at the divider (a fraction of the width),
    a 2-pixel white line between them and each side's label in its top corner."""
    h, w = left.shape[:2]
    x = int(round(split * w))
    out = left.copy()
    out[:, x:] = right[:, x:]
    out[:, max(0, x - 1):min(w, x + 1)] = 255
    return _label(_label(out, labels[0], 4, "left"), labels[1], w - 4, "right")


def _label(image: np.ndarray, text: str, x: int, anchor: str) -> np.ndarray:
    """Text on a dark box at the top of the image, starting (left) or ending (right) at x."""
    from PIL import Image, ImageDraw, ImageFont

    img = Image.fromarray(image)
    draw = ImageDraw.Draw(img)
    size = max(10, min(18, image.shape[0] // 20))
    try:
        font = ImageFont.load_default(size=size)
    except TypeError:  # Pillow < 10.1: the fixed bitmap font
        font = ImageFont.load_default()
    box = draw.textbbox((0, 0), text, font=font)
    tw, th = box[2] - box[0], box[3] - box[1]
    x0 = x if anchor == "left" else x - tw - 6
    draw.rectangle((x0, 2, x0 + tw + 6, 2 + th + 6), fill=(0, 0, 0))
    draw.text((x0 + 3 - box[0], 5 - box[1]), text, fill=(255, 255, 255), font=font)
    return np.asarray(img)
