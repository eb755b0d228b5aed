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


def flip_map(reference: np.ndarray, test: np.ndarray, values: bool = False):
    """(H x W x 3 uint8 magma-coloured FLIP error map, mean FLIP) of two sRGB uint8 images;
    with values, also the H x W x 3 float32 error itself (each pixel's FLIP in all 3 channels)."""
    import flip_evaluator as flip

    ref = np.ascontiguousarray(reference.astype(np.float32) / 255.0)
    tst = np.ascontiguousarray(test.astype(np.float32) / 255.0)
    error, mean, _ = flip.evaluate(ref, tst, "LDR", applyMagma=True)
    coloured = np.clip(np.asarray(error)[..., :3] * 255.0 + 0.5, 0, 255).astype(np.uint8)
    if not values:
        return coloured, float(mean)
    plain = np.asarray(flip.evaluate(ref, tst, "LDR", applyMagma=False)[0], np.float32)
    plain = plain.reshape(plain.shape[0], plain.shape[1], -1)[..., :1]
    return coloured, float(mean), np.repeat(plain, 3, axis=2)


def split_columns(left: np.ndarray, right: np.ndarray, split: float) -> np.ndarray:
    """The left image up to the divider (a fraction of the width), the right one from it on:
    the same columns for the PNG and for the raw image of a comparison."""
    x = int(round(split * left.shape[1]))
    out = left.copy()
    out[:, x:] = right[:, x:]
    return out


def compose(left: np.ndarray, right: np.ndarray, split: float, labels: tuple[str, str]) -> np.ndarray:
    """The two H x W x 3 uint8 images side by side at the divider (a fraction of the width),
    a 2-pixel white line between them and each side's label in its top corner (place_labels)."""
    w = left.shape[1]
    x = int(round(split * w))
    out = split_columns(left, right, split)
    out[:, max(0, x - 1):min(w, x + 1)] = 255
    return place_labels(out, labels)


def place_labels(image: np.ndarray, labels: tuple[str, str]) -> np.ndarray:
    """The two labels drawn where label_layout puts them, white on dark boxes."""
    from PIL import Image, ImageDraw

    img = Image.fromarray(image)
    draw = ImageDraw.Draw(img)
    font, texts, boxes = label_layout(draw, image.shape[1], image.shape[0], labels)
    for text, (x0, y0, x1, y1) in zip(texts, boxes, strict=True):
        left, top = draw.textbbox((0, 0), text, font=font)[:2]
        draw.rectangle((x0, y0, x1, y1), fill=(0, 0, 0))
        draw.text((x0 + 3 - left, y0 + 3 - top), text, fill=(255, 255, 255), font=font)
    return np.asarray(img)


def label_layout(draw, width: int, height: int, labels: tuple[str, str]):
    """(font, texts, their boxes (x0, y0, x1, y1)): the left label at the top left, the right one
    at the top right, in the largest font (10-18 px by the image's height, down to 8) at which
    they fit side by side; where they do not, the right one on a second row; a label wider than
    the image cut short with "..."."""
    def side_by_side(texts, font) -> bool:  # both boxes (text + 6), the margins and a gap
        return sum(_text_box(draw, t, font)[0] + 6 for t in texts) + 16 <= width

    for size in range(max(10, min(18, height // 20)), 7, -1):
        font = _font(size)
        if side_by_side(labels, font):
            break
    texts = [_fitted(draw, t, font, width - 8) for t in labels]
    (w0, h0), (w1, h1) = (_text_box(draw, t, font) for t in texts)
    y1 = 2 if side_by_side(texts, font) else 2 + h0 + 6 + 2
    return font, texts, [(4, 2, 4 + w0 + 6, 2 + h0 + 6), (width - 4 - w1 - 6, y1, width - 4, y1 + h1 + 6)]


def _font(size: int):
    from PIL import ImageFont

    try:
        return ImageFont.load_default(size=size)
    except TypeError:  # Pillow < 10.1: the fixed bitmap font
        return ImageFont.load_default()


def _text_box(draw, text: str, font) -> tuple[int, int]:
    box = draw.textbbox((0, 0), text, font=font)
    return box[2] - box[0], box[3] - box[1]


def _fitted(draw, text: str, font, width: int) -> str:
    """The text, or as much of it as fits in width pixels (with its box) followed by "..."."""
    if _text_box(draw, text, font)[0] + 6 <= width:
        return text
    while len(text) > 1 and _text_box(draw, text + "...", font)[0] + 6 > width:
        text = text[:-1]
    return text + "..."
