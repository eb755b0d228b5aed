"""The end of an Embree frame on the tracer's threads (Backend.present, where option `finish`
puts it there: app/graph.py finish_on_tracer): the running mean of the frames, as
shaders/accumulate.frag, then exposure, the ACES fit and sRGB, as shaders/tonemap.frag, into
8-bit RGBA rows bottom-up as GL stores a texture. Only that image goes to GL, a quarter of the
float one, and a CPU rasteriser's two full-screen passes are not run.

sRGB's pow(c, 1 / 2.4) is a polynomial in c^(1/4) (two square roots), fitted once here: within
0.001 of an 8-bit step of the exact curve, and unlike libm's pow it vectorises."""
from __future__ import annotations

import numpy as np

from rt.embree.jit import njit
from rt.embree.kernels import next_block

F = np.float32
ZERO, ONE = F(0.0), F(1.0)
SRGB_KNEE = F(0.0031308)  # below it sRGB is linear (x 12.92)


def _srgb_fit() -> tuple:
    """1.055 c^(1/2.4) - 0.055 on [SRGB_KNEE, 1] as p(c^(1/4)), p of degree 6, coefficients lowest first."""
    q = np.linspace(float(SRGB_KNEE) ** 0.25, 1.0, 4097)
    p = np.polynomial.Chebyshev.fit(q, q ** (5.0 / 3.0), 6).convert(kind=np.polynomial.Polynomial).coef * 1.055
    p[0] -= 0.055
    return tuple(F(c) for c in p)


S0, S1, S2, S3, S4, S5, S6 = _srgb_fit()


@njit(cache=True, error_model="numpy", nogil=True, fastmath=True)
def _tone_row(radiance, mean, out, weight, exposure, restart, keep):
    """One row's floats (3 a pixel): the running mean (restart: the radiance itself; keep: the
    mean as it is; else the mean moved weight of the way to the radiance) into mean, and its
    sRGB-encoded ACES-mapped value into out."""
    for i in range(radiance.shape[0]):
        m = mean[i]
        r = radiance[i]
        c = m + (r - m) * weight
        c = r if restart else c
        c = m if keep else c
        mean[i] = c
        v = max(c, ZERO) * exposure
        a = min(max((v * (F(2.51) * v + F(0.03))) / (v * (F(2.43) * v + F(0.59)) + F(0.14)), ZERO), ONE)
        q = np.sqrt(np.sqrt(a))
        s = S0 + q * (S1 + q * (S2 + q * (S3 + q * (S4 + q * (S5 + q * S6)))))
        out[i] = a * F(12.92) if a < SRGB_KNEE else s


@njit(cache=True, error_model="numpy", nogil=True, fastmath=True)
def _unorm8(v):
    return np.uint32(min(max(v, ZERO), ONE) * F(255.0) + F(0.5))


@njit(cache=True, error_model="numpy", nogil=True, fastmath=True)
def _pack_row(t, display):
    """RGBA8 from a row's sRGB values, luma in alpha (as tonemap.frag writes it for FXAA)."""
    for x in range(display.shape[0]):
        r, g, b = t[3 * x], t[3 * x + 1], t[3 * x + 2]
        luma = F(0.299) * r + F(0.587) * g + F(0.114) * b
        display[x] = _unorm8(r) | (_unorm8(g) << 8) | (_unorm8(b) << 16) | (_unorm8(luma) << 24)


@njit(cache=True, error_model="numpy", nogil=True)
def present_frame(counter, bounds, radiance, mean, display, width, height, weight, exposure):
    """One worker of Tracer.run_parallel over the image's pixels (radiance and mean: 3 floats a
    pixel, top row first; display: one uint32 a pixel, bottom row first): blocks of pixels,
    row by row. weight: 1 / (frames so far + 1); 1 restarts the mean, 0 keeps it."""
    n = width * height
    t = np.empty(3 * width, F)
    restart, keep = weight >= ONE, weight <= ZERO
    while True:
        b0, b1 = next_block(counter, bounds)
        if b0 >= n:
            return 0
        p = b0
        while p < b1:
            y = p // width
            x0 = p - y * width
            x1 = min(width, x0 + b1 - p)
            k = x1 - x0
            _tone_row(radiance[3 * p:3 * (p + k)], mean[3 * p:3 * (p + k)], t[:3 * k], weight, exposure, restart,
                      keep)
            row = (height - 1 - y) * width
            _pack_row(t[:3 * k], display[row + x0:row + x1])
            p += k


def present(tracer, radiance: np.ndarray, mean: np.ndarray, display: np.ndarray, width: int, height: int,
            weight: float, exposure: float) -> None:
    """present_frame over the whole image on the tracer's threads (radiance, mean: (n, 3)
    float32; display: (height, width, 4) uint8)."""
    tracer.run_parallel(present_frame, width * height, radiance.reshape(-1), mean.reshape(-1),
                        display.reshape(-1).view(np.uint32), width, height, F(weight), F(exposure))
