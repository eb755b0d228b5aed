"""The per-point light weights that one-light sampling picks by (rt/raygen.py)."""
import numpy as np

from rt import raygen


def reference_weights(P, N, guide):
    """Each light's estimated contribution at each point, as _light_weights documents it."""
    lx, ly, lz, sx, sy, sz, lum, cos_out, spot_scale, sun, cx, cy, cz, radius, power = guide
    rows = []
    for k in range(lx.size):
        v = np.array([lx[k], ly[k], lz[k]]) - P
        d2 = np.maximum((v * v).sum(1), 1e-12)
        inv = 1 / np.sqrt(d2)
        d = np.array([sx[k], sy[k], sz[k]])
        if sun[k]:
            rows.append(lum[k] * (np.maximum(-(N @ d), 0) + 1e-6))
            continue
        t = np.clip((-(v @ d) * inv - cos_out[k]) * spot_scale[k], 0, 1)
        rows.append(lum[k] * np.maximum((N * v).sum(1) * inv, 0) * inv * inv * t * t)
    for j in range(cx.size):
        v = np.array([cx[j], cy[j], cz[j]]) - P
        d2 = np.maximum((v * v).sum(1), 1e-12)
        inv = 1 / np.sqrt(d2)
        sin_r = np.minimum(radius[j] * inv, 1)
        cb = np.clip((N * v).sum(1) * inv + sin_r, 0, 1)
        cb = np.where(sin_r < 1, cb, 1)
        r2 = radius[j] ** 2
        rows.append(power[j] * np.maximum(cb, 0.02) / np.maximum(d2 - r2, r2 * 0.25 + 1e-12))
    return np.array(rows)


def test_light_weights_are_running_sums_of_each_kinds_estimate():
    rng = np.random.default_rng(3)
    n = 50
    P = rng.uniform(-2, 2, (n, 3)).astype(np.float32)
    N = rng.normal(size=(n, 3)).astype(np.float32)
    N /= np.linalg.norm(N, axis=1, keepdims=True)
    f = lambda *a: np.array(a, np.float32)  # noqa: E731
    # a point light, a spot, a sun, another point; then two emissive clusters (one enclosing points)
    pos = f([0, 3, 0], [1, 2, -1], [0, 0, 0], [-3, 1, 2])
    d = f([0, 0, 1], [0, -1, 0], [0.6, -0.8, 0], [1, 0, 0])
    guide = (*(np.ascontiguousarray(pos[:, a]) for a in range(3)), *(np.ascontiguousarray(d[:, a]) for a in range(3)),
             f(5, 2, 1, 3), f(-2, 0.7, -2, -2), f(1, 1 / 0.2, 1, 1), np.array([False, False, True, False]),
             f(0, 4), f(4, 0), f(0, 0), f(0.5, 3.0), f(2, 7))
    w = np.zeros((6, raygen.BLOCK), np.float32)
    run = np.zeros(raygen.BLOCK, np.float32)
    raygen._light_weights(*(np.ascontiguousarray(P[:, a]) for a in range(3)),
                          *(np.ascontiguousarray(N[:, a]) for a in range(3)), n, guide, w, run)
    want = np.cumsum(reference_weights(P.astype(np.float64), N.astype(np.float64), guide), axis=0)
    np.testing.assert_allclose(w[:, :n], want, rtol=2e-4, atol=1e-9)
    np.testing.assert_allclose(run[:n], want[-1], rtol=2e-4)
    assert (np.diff(w[:, :n], axis=0) >= 0).all()  # every light keeps a share (the sun one, clusters always)
    assert (w[4:, :n] > w[3:5, :n]).all()
