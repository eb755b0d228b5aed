"""Image quality against the reference path tracer: mean FLIP (NVIDIA's flip-evaluator,
LDR, on the tone-mapped images users see) and PSNR (on the same 8-bit images)."""
from __future__ import annotations

import numpy as np


def to_display(linear: np.ndarray, exposure: float = 1.0) -> np.ndarray:
    """A linear image as the display shows it (shaders/tonemap.frag: exposure, ACES, sRGB), 8-bit."""
    x = np.maximum(linear.astype(np.float64), 0.0) * exposure
    c = np.clip((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14), 0.0, 1.0)
    c = np.where(c <= 0.0031308, c * 12.92, 1.055 * np.power(c, 1.0 / 2.4) - 0.055)
    return np.round(np.clip(c, 0.0, 1.0) * 255.0).astype(np.uint8)


def rmse(a: np.ndarray, b: np.ndarray) -> float:
    """Root-mean-square difference of two 8-bit images, in [0, 1] units."""
    return float(np.sqrt(np.mean((a.astype(np.float64) / 255.0 - b.astype(np.float64) / 255.0) ** 2)))


def psnr(reference: np.ndarray, test: np.ndarray) -> float:
    a = reference.astype(np.float64) / 255.0
    b = test.astype(np.float64) / 255.0
    mse = float(np.mean((a - b) ** 2))
    return 99.0 if mse < 1e-10 else min(99.0, 10.0 * np.log10(1.0 / mse))  # capped: JSON has no inf


def mean_bias(reference: np.ndarray, test: np.ndarray) -> float:
    """The test image's mean brightness against the reference's, relative, in linear light (two
    sRGB uint8 images; the sRGB curve undone): a filter's bias, apart from its noise."""
    ref = _linear(reference).mean()
    return float((_linear(test).mean() - ref) / ref) if ref > 0 else 0.0


def _flip(reference: np.ndarray, test: np.ndarray, magma: bool):
    import flip_evaluator as flip

    ref = np.ascontiguousarray(reference[..., :3].astype(np.float32) / 255.0)
    tst = np.ascontiguousarray(test[..., :3].astype(np.float32) / 255.0)
    image, value, _ = flip.evaluate(ref, tst, "LDR", applyMagma=magma)
    return image, float(value)


def _linear(image: np.ndarray) -> np.ndarray:
    """An sRGB uint8 image's RGB in linear light (the sRGB curve undone), float64."""
    c = image[..., :3].astype(np.float64) / 255.0
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def rel_mse(reference: np.ndarray, test: np.ndarray) -> float:
    """Relative mean squared error in linear light, as denoising papers report it: each
    channel's squared error over the reference's square (+0.01, so that black does not blow up):
    bias and noise together, weighted alike in dark and bright regions."""
    r, t = _linear(reference), _linear(test)
    return float(np.mean((t - r) ** 2 / (r * r + 0.01)))


def flicker(images: list[np.ndarray]) -> float:
    """Temporal flicker of a still view: the mean absolute change of a pixel's displayed
    luminance (0..1) from one frame to the next, over consecutive sRGB uint8 frames."""
    lum = np.array([0.2126, 0.7152, 0.0722])
    y = [image[..., :3].astype(np.float64) @ lum / 255.0 for image in images]
    return float(np.mean([np.abs(b - a).mean() for a, b in zip(y, y[1:], strict=False)])) if len(y) > 1 else 0.0


def mean_flip(reference: np.ndarray, test: np.ndarray) -> float:
    """Mean LDR FLIP of two sRGB uint8 images (0 = identical, 1 = maximal difference)."""
    return _flip(reference, test, False)[1]


def flip_map(reference: np.ndarray, test: np.ndarray) -> tuple[float, np.ndarray]:
    """Mean LDR FLIP of two sRGB uint8 images and the per-pixel error as FLIP's magma map
    (black = no visible difference, yellow = the largest), 8-bit RGB."""
    image, value = _flip(reference, test, True)
    return value, np.round(np.clip(image, 0.0, 1.0) * 255.0).astype(np.uint8)
