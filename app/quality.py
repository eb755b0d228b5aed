"""Image quality against the reference path tracer: mean FLIP (NVIDIA's flip-evaluator,
LDR, on the tone-mapped images users see) and PSNR (on the same 8-bit images)."""
from __future__ import annotations

import numpy as np


def psnr(reference: np.ndarray, test: np.ndarray) -> float:
    a = reference.astype(np.float64) / 255.0
    b = test.astype(np.float64) / 255.0
    mse = float(np.mean((a - b) ** 2))
    return 99.0 if mse < 1e-10 else min(99.0, 10.0 * np.log10(1.0 / mse))  # capped: JSON has no inf


def mean_flip(reference: np.ndarray, test: np.ndarray) -> float:
    """Mean LDR FLIP of two sRGB uint8 images (0 = identical, 1 = maximal difference)."""
    import flip_evaluator as flip

    ref = np.ascontiguousarray(reference.astype(np.float32) / 255.0)
    tst = np.ascontiguousarray(test.astype(np.float32) / 255.0)
    _, value, _ = flip.evaluate(ref, tst, "LDR", applyMagma=False)
    return float(value)
