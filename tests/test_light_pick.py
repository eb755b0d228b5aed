"""The per-point light weights that one-light sampling picks by (rt/embree/raygen.py)."""
import numpy as np

from rt.embree import light_sampling, raygen, rtcore


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
    w = np.zeros((6, light_sampling.BLOCK), np.float32)
    run = np.zeros(light_sampling.BLOCK, np.float32)
    light_sampling._light_weights(*(np.ascontiguousarray(P[:, a]) for a in range(3)),
                          *(np.ascontiguousarray(N[:, a]) for a in range(3)), n, guide, w, run)
    want = np.cumsum(reference_weights(P.astype(np.float64), N.astype(np.float64), guide), axis=0)
    np.testing.assert_allclose(w[:, :n], want, rtol=2e-4, atol=1e-9)
    np.testing.assert_allclose(run[:n], want[-1], rtol=2e-4)
    assert (np.diff(w[:, :n], axis=0) >= 0).all()  # every light keeps a share (the sun one, clusters always)
    assert (w[4:, :n] > w[3:5, :n]).all()


def _lights():
    """A point light, a spot, a sun and an emissive cluster of two triangles (one double-sided),
    as LightSet.analytic, .emitters and .guide hold them."""
    f = lambda *a: np.array(a, np.float32)  # noqa: E731
    kind = np.array([0, 1, 2], np.int32)
    pos, d = f([0, 3, 0], [1, 2, -1], [0, 0, 0]), f([0, 0, 1], [0, -1, 0], [0.6, -0.8, 0])
    rad, cos_out, spot_scale, cos_ang = f([5, 4, 3], [2, 2, 1], [1, 1, 0.5]), f(0.5, 0.7, 1), f(1, 5, 1), f(1, 1, 0.995)
    lum = rad @ f(0.2126, 0.7152, 0.0722)
    analytic = (kind, pos, d, rad, cos_out, spot_scale, cos_ang, lum)
    rows = np.zeros((2, 16), np.float32)
    rows[0, :12] = [-1, 2.5, -1, 1, 0, 0, 0, 0, 1, 0, -1, 0]
    rows[1, :12] = [2, 1, 2, 0, 1, 0, 0, 0, -1, -1, 0, 0]
    rows[:, 12:15], rows[:, 15] = [[3, 3, 2], [1, 2, 3]], [0, 1]
    emitters = (np.array([0, 2], np.int64), rows, f(0.6, 1.0), np.array([1, 1], np.int32))
    spot = kind == 1
    col = np.ascontiguousarray
    guide = (*(col(pos[:, a]) for a in range(3)), *(col(d[:, a]) for a in range(3)), lum,
             col(np.where(spot, cos_out, -2).astype(np.float32)), col(np.where(spot, spot_scale, 1).astype(np.float32)),
             kind == 2, f(0.5), f(1.75), f(0.5), f(2.0), f(9.0))
    return analytic, emitters, guide


def reference_one_light(P, N, keys, dim, analytic, emitters, guide, far):
    """Per point: the light picked, the direction, distance and light carried (x cos) of its ray."""
    from rt.embree.kernels import uniform

    kind, pos, d, rad, cos_out, spot_scale, cos_ang, _ = analytic
    start, rows, keep, alias = emitters
    w = np.cumsum(reference_weights(P, N, guide), axis=0)
    out = []
    for i in range(len(P)):
        u = [float(uniform(keys[i], dim + j)) for j in range(4)]
        k = int((w[:-1, i] <= u[0] * w[-1, i]).sum())
        inv = w[-1, i] / (w[k, i] - (w[k - 1, i] if k else 0))
        if k < len(kind) and kind[k] == 2:
            ct = 1 - u[1] * (1 - cos_ang[k])
            st = np.sqrt(max(0.0, 1 - ct * ct))
            x, y = st * np.cos(2 * np.pi * u[2]), st * np.sin(2 * np.pi * u[2])
            direction = np.array(raygen.about(*(-d[k]), np.float32(x), np.float32(y), np.float32(ct)))
            out.append((k, direction, far, rad[k] * inv, ct))
            continue
        if k < len(kind):
            v = pos[k] - P[i]
            dist = np.linalg.norm(v)
            direction = v / dist
            t = 1.0 if kind[k] == 0 else np.clip((-(direction @ d[k]) - cos_out[k]) * spot_scale[k], 0, 1)
            e = rad[k] * t * t / dist ** 2 * inv
        else:
            lo, hi = start[k - 3], start[k - 3 + 1]
            x = u[1] * (hi - lo)
            slot = min(int(x), hi - lo - 1)
            j = lo + slot if x - slot < keep[lo + slot] else lo + alias[lo + slot]
            su = np.sqrt(u[2])
            q = rows[j, 0:3] + rows[j, 3:6] * su * (1 - u[3]) + rows[j, 6:9] * su * u[3]
            v = q - P[i]
            dist = np.linalg.norm(v)
            direction = v / dist
            cl = -(rows[j, 9:12] @ direction)
            cl = abs(cl) if rows[j, 15] else max(cl, 0)
            e = rows[j, 12:15] * cl / dist ** 2 * inv
            dist *= 1 - 1e-4
        out.append((k, direction, dist, e, None))
    return out


def test_each_point_traces_towards_the_light_it_picked_divided_by_its_probability():
    rng = np.random.default_rng(5)
    n = light_sampling.BLOCK + 150  # more than one block of points
    P = rng.uniform(-2, 2, (n, 3)).astype(np.float32)
    N = rng.normal(size=(n, 3)).astype(np.float32)
    N /= np.linalg.norm(N, axis=1, keepdims=True)
    G = np.ascontiguousarray(np.concatenate([P.T, N.T, N.T]), np.float32)
    keys = rng.integers(0, 2**63, n, dtype=np.int64).astype(np.uint64)
    analytic, emitters, guide = _lights()
    far, dim = 50.0, 7
    weights = np.empty((5 + light_sampling.SCRATCH_ROWS, light_sampling.BLOCK), np.float32)
    o, dirs, tmax, e = (np.zeros((n, 3), np.float32), np.zeros((n, 3), np.float32), np.zeros(n, np.float32),
                        np.zeros((n, 3), np.float32))
    idx = np.zeros(n, np.int32)
    m = light_sampling.one_light_shadow_rays(G, 0, keys, dim, (analytic, emitters, guide), np.float32(far),
                                             weights, (o, dirs, tmax, e, idx), rtcore.target(0), raygen.NOT_TRACED)
    ref = reference_one_light(P.astype(np.float64), N.astype(np.float64), keys, dim, analytic, emitters, guide, far)
    kept = [i for i, (k, direction, dist, light, _) in enumerate(ref) if direction @ N[i] > 0 and light.max() > 0]
    assert list(idx[:m]) == kept
    picked = {r[0] for r in ref}
    assert picked == {0, 1, 2, 3}  # every kind was picked somewhere
    for j, i in enumerate(kept):
        k, direction, dist, light, cone = ref[i]
        cs = direction @ N[i]
        np.testing.assert_allclose(dirs[j], direction, atol=2e-5)
        if cone is not None:  # a sun: a direction in its cone, at the cosine drawn
            np.testing.assert_allclose(dirs[j] @ -analytic[2][k], cone, atol=1e-5)
        else:
            np.testing.assert_allclose(tmax[j] / (1 - raygen.SHADOW_SHORTEN), dist, rtol=1e-4)
        np.testing.assert_allclose(e[j], light * cs, rtol=2e-4, atol=1e-8)


def _only(k):
    """_lights() reduced to its analytic light k alone (no emitters)."""
    analytic, _, guide = _lights()
    one = tuple(np.ascontiguousarray(a[k:k + 1]) for a in analytic)
    emitters = (np.array([0], np.int64), np.zeros((0, 16), np.float32), np.zeros(0, np.float32),
                np.zeros(0, np.int32))
    empty = np.zeros(0, np.float32)
    return one, emitters, (*(np.ascontiguousarray(g[k:k + 1]) for g in guide[:10]), *(empty,) * 5)


def test_a_single_light_is_sampled_as_when_picked_among_others():
    """With one light the pick is skipped (raygen: single); the rays are those of the pick."""
    rng = np.random.default_rng(8)
    n = 150
    P = rng.uniform(-2, 2, (n, 3)).astype(np.float32)
    N = rng.normal(size=(n, 3)).astype(np.float32)
    N /= np.linalg.norm(N, axis=1, keepdims=True)
    G = np.ascontiguousarray(np.concatenate([P.T, N.T, N.T]), np.float32)
    keys = rng.integers(0, 2**63, n, dtype=np.int64).astype(np.uint64)
    far, dim = 50.0, 3
    for k in range(3):  # the point light, the spot, the sun
        analytic, emitters, guide = _only(k)
        weights = np.empty((1 + light_sampling.SCRATCH_ROWS, light_sampling.BLOCK), np.float32)
        o, dirs, tmax, e = (np.zeros((n, 3), np.float32), np.zeros((n, 3), np.float32), np.zeros(n, np.float32),
                            np.zeros((n, 3), np.float32))
        idx = np.zeros(n, np.int32)
        m = light_sampling.one_light_shadow_rays(G, 0, keys, dim, (analytic, emitters, guide), np.float32(far),
                                                 weights, (o, dirs, tmax, e, idx), rtcore.target(0),
                                                 raygen.NOT_TRACED)
        with np.errstate(invalid="ignore"):  # 0 / 0 where the light has no weight: those carry nothing
            ref = reference_one_light(P.astype(np.float64), N.astype(np.float64), keys, dim, analytic, emitters,
                                      guide, far)
        kept = [i for i, (_, direction, _, light, _) in enumerate(ref) if direction @ N[i] > 0 and light.max() > 0]
        assert m > n // 4 and list(idx[:m]) == kept
        for j, i in enumerate(kept):
            _, direction, _, light, _ = ref[i]
            np.testing.assert_allclose(dirs[j], direction, atol=2e-5)
            np.testing.assert_allclose(e[j], light * (direction @ N[i]), rtol=2e-4, atol=1e-8)
