"""glTF's metal-rough BRDF in the Embree kernels (option `brdf=ggx`; the formulas are in
docs/ARCHITECTURE.md "Materials", and the same in shaders/common.glsl and shaders/rt/brdf.slang):

    f(v, l) = c_diff (1 - F) / pi + F D V,   c_diff = base (1 - metallic),
    F = F0 + (1 - F0) w,  w = (1 - v.h)^5,   F0 = 0.04 (1 - metallic) + base metallic,
    D = a2 / (pi ((n.h)^2 (a2 - 1) + 1)^2),  a = roughness^2,
    V = G1(v) G1(l) / (4 n.l n.v) = 1 / ((n.v + L(n.v)) (n.l + L(n.l))),  L(c) = sqrt(a2 + (1 - a2) c^2)

(Smith's separable shadowing-masking, as Mitsuba 3's GGX). Direct light adds up per point
before the material is applied, so a point's light accumulator keeps four sums per channel over
its light samples e (irradiance x cos): e, e w, e D V and e D V w, from which the radiance is

    c_diff (1 - F0) / pi (sum e - sum e w) + F0 sum e D V + (1 - F0) sum e D V w.

Such an accumulator has GGX_COLS columns: the sums, then the point's view direction (towards
the viewer) and its alpha, written before the light is sampled (start) and read where a light
sample is added (add_light, in rt/embree/raygen.py); the reference path tracer's have one more,
the specular lobe's share (P_SPEC), with which its emitters' samples are weighted against the
BRDF's drawing of their directions (light_sampling._mis_weights). A plain accumulator (3 columns) keeps the
sum of e alone: the study's Lambert model."""
from __future__ import annotations

import numpy as np

from rt.embree.jit import njit

F = np.float32
ZERO, ONE = F(0.0), F(1.0)
INV_PI = F(1 / np.pi)
MIN_ALPHA = F(1e-3)
MIN_COS = F(1e-4)
MIRROR_ROUGHNESS = 0.1  # smoother: the reference path tracer's specular lobe is reached by bounces alone
SUM_E, SUM_EW, SUM_EDV, SUM_EDVW, VIEW, ALPHA = 0, 3, 6, 9, 12, 15
GGX_COLS = 16
P_SPEC = 16  # a 17th column (the reference's accumulators): the specular lobe's share, for MIS (lobes_density)


@njit(cache=True, error_model="numpy", fastmath=True)
def alpha(roughness):
    return max(roughness * roughness, MIN_ALPHA)


@njit(cache=True, error_model="numpy", fastmath=True)
def ggx_terms(nx, ny, nz, vx, vy, vz, lx, ly, lz, a):
    """(w, D V) for unit normal n, view v, light l and alpha a (module notes)."""
    hx, hy, hz = vx + lx, vy + ly, vz + lz
    hl = np.sqrt(hx * hx + hy * hy + hz * hz)
    inv = ONE / hl if hl > F(1e-12) else ZERO
    hx, hy, hz = hx * inv, hy * inv, hz * inv
    k = ONE - min(max(vx * hx + vy * hy + vz * hz, ZERO), ONE)
    w = k * k * k * k * k
    nh = max(nx * hx + ny * hy + nz * hz, ZERO)
    nv = max(nx * vx + ny * vy + nz * vz, MIN_COS)
    nl = max(nx * lx + ny * ly + nz * lz, MIN_COS)
    a2 = a * a
    t = nh * nh * (a2 - ONE) + ONE
    d = a2 * INV_PI / (t * t)
    vis = ONE / ((nv + np.sqrt(a2 + (ONE - a2) * nv * nv)) * (nl + np.sqrt(a2 + (ONE - a2) * nl * nl)))
    return w, d * vis


@njit(cache=True, error_model="numpy", fastmath=True)
def add_light(acc, i, ex, ey, ez, nx, ny, nz, lx, ly, lz):
    """acc[i] gains light sample (ex, ey, ez) (irradiance x cos) arriving along unit (lx, ly, lz)
    at a point of shading normal n: its sum, and with GGX_COLS columns the GGX terms' sums."""
    acc[i, 0] += ex
    acc[i, 1] += ey
    acc[i, 2] += ez
    if acc.shape[1] < GGX_COLS:
        return
    w, dv = ggx_terms(nx, ny, nz, acc[i, VIEW], acc[i, VIEW + 1], acc[i, VIEW + 2], lx, ly, lz, acc[i, ALPHA])
    acc[i, SUM_EW] += ex * w
    acc[i, SUM_EW + 1] += ey * w
    acc[i, SUM_EW + 2] += ez * w
    acc[i, SUM_EDV] += ex * dv
    acc[i, SUM_EDV + 1] += ey * dv
    acc[i, SUM_EDV + 2] += ez * dv
    acc[i, SUM_EDVW] += ex * dv * w
    acc[i, SUM_EDVW + 1] += ey * dv * w
    acc[i, SUM_EDVW + 2] += ez * dv * w


@njit(cache=True, error_model="numpy", fastmath=True)
def f0(base, metallic):
    return F(0.04) * (ONE - metallic) + base * metallic


@njit(cache=True, error_model="numpy", fastmath=True)
def outgoing(acc, i, a, base, metallic):
    """The direct radiance, channel a, that accumulator row acc[i] (GGX_COLS columns) gives a
    material of base colour `base` (that channel) and `metallic`."""
    c = base * (ONE - metallic)
    r = f0(base, metallic)
    return (c * INV_PI * (ONE - r) * (acc[i, SUM_E + a] - acc[i, SUM_EW + a]) + r * acc[i, SUM_EDV + a]
            + (ONE - r) * acc[i, SUM_EDVW + a])


@njit(cache=True, error_model="numpy", fastmath=True)
def specular_out(acc, i, a, base, metallic):
    """outgoing's specular lobe alone: F0 sum e D V + (1 - F0) sum e D V w."""
    r = f0(base, metallic)
    return r * acc[i, SUM_EDV + a] + (ONE - r) * acc[i, SUM_EDVW + a]


@njit(cache=True, error_model="numpy", fastmath=True)
def light_out(acc, i, a, base, metallic):
    """Direct radiance leaving point i, channel a, from its accumulator: GGX (GGX_COLS columns)
    or Lambert (base / pi x the sum)."""
    if acc.shape[1] >= GGX_COLS:
        return outgoing(acc, i, a, base, metallic)
    return base * acc[i, a] * INV_PI


@njit(cache=True, error_model="numpy", nogil=True, fastmath=True)
def accumulator(ggx, D, rows, rough):
    """A zeroed light accumulator for the points i < len(rows) seen along ray directions
    D[rows[i]] (from the viewer towards the point), of roughness rough[i]: 3 columns, or with
    ggx GGX_COLS with each point's view direction (-D) and alpha."""
    n = rows.shape[0]
    if not ggx:
        return np.zeros((n, 3), np.float32)
    acc = np.zeros((n, GGX_COLS), np.float32)
    for i in range(n):
        r = rows[i]
        acc[i, VIEW], acc[i, VIEW + 1], acc[i, VIEW + 2] = -D[r, 0], -D[r, 1], -D[r, 2]
        acc[i, ALPHA] = alpha(rough[i])
    return acc


GLOSSY_DIM = 72  # the reflections pass's glossy rays: their two numbers (above every mirror level's lights)
REFLECTION_ENV_DIM = 74  # its environment samples, 3 numbers each: the points' from here, level l's hits' 3 (l + 1) on


@njit(cache=True, error_model="numpy", fastmath=True)
def _frame(nx, ny, nz):
    """A tangent t and bitangent b about unit n (sample_visible_normal's frame)."""
    if abs(nx) > F(0.9):
        tx, ty, tz = -nx * ny, ONE - ny * ny, -nz * ny
    else:
        tx, ty, tz = ONE - nx * nx, -ny * nx, -nz * nx
    inv = ONE / np.sqrt(tx * tx + ty * ty + tz * tz)
    tx, ty, tz = tx * inv, ty * inv, tz * inv
    return tx, ty, tz, ny * tz - nz * ty, nz * tx - nx * tz, nx * ty - ny * tx


@njit(cache=True, error_model="numpy", fastmath=True)
def visible_normal(nx, ny, nz, vx, vy, vz, a, u0, u1):
    """sample_visible_normal (below) for one point: a GGX microfacet normal about n seen from v."""
    tx, ty, tz, bx, by, bz = _frame(nx, ny, nz)
    lx, ly, lz = a * (vx * tx + vy * ty + vz * tz), a * (vx * bx + vy * by + vz * bz), max(vx * nx + vy * ny + vz * nz,
                                                                                            MIN_COS)
    inv = ONE / np.sqrt(lx * lx + ly * ly + lz * lz)
    hx, hy, hz = lx * inv, ly * inv, lz * inv
    lensq = hx * hx + hy * hy
    if lensq > ZERO:
        k = ONE / np.sqrt(lensq)
        t1x, t1y, t1z = -hy * k, hx * k, ZERO
    else:
        t1x, t1y, t1z = ONE, ZERO, ZERO
    t2x, t2y, t2z = hy * t1z - hz * t1y, hz * t1x - hx * t1z, hx * t1y - hy * t1x
    r, phi = np.sqrt(u0), F(2 * np.pi) * u1
    p1, p2 = r * np.cos(phi), r * np.sin(phi)
    s = F(0.5) * (ONE + hz)
    p2 = (ONE - s) * np.sqrt(max(ONE - p1 * p1, ZERO)) + s * p2
    p3 = np.sqrt(max(ONE - p1 * p1 - p2 * p2, ZERO))
    mx, my, mz = p1 * t1x + p2 * t2x + p3 * hx, p1 * t1y + p2 * t2y + p3 * hy, p1 * t1z + p2 * t2z + p3 * hz
    mx, my, mz = a * mx, a * my, max(mz, ZERO)
    inv = ONE / np.sqrt(mx * mx + my * my + mz * mz)
    mx, my, mz = mx * inv, my * inv, mz * inv
    return (mx * tx + my * bx + mz * nx, mx * ty + my * by + mz * ny, mx * tz + my * bz + mz * nz)


@njit(cache=True, error_model="numpy", fastmath=True)
def lobes_density(p_spec, a, vx, vy, vz, nx, ny, nz, x, y, z):
    """The density with which the BRDF's lobes (the specular picked with p_spec) draw (x, y, z):
    p_spec x GGX's visible normals reflected (G1(v) D(h) / (4 n.v)) + (1 - p_spec) x the cosine's."""
    out = (ONE - p_spec) * max(nx * x + ny * y + nz * z, ZERO) * INV_PI
    if p_spec > ZERO:
        out += p_spec * visible_normal_density(nx, ny, nz, vx, vy, vz, x, y, z, a)
    return out


@njit(cache=True, error_model="numpy", fastmath=True)
def g1(c, a):
    c = max(c, MIN_COS)
    return F(2.0) * c / (c + np.sqrt(a * a + (ONE - a * a) * c * c))


@njit(cache=True, error_model="numpy", fastmath=True)
def visible_normal_density(nx, ny, nz, vx, vy, vz, lx, ly, lz, a):
    """The density per solid angle with which l is v reflected about a normal drawn by
    visible_normal: G1(v) D(h) / (4 n.v) (visible_normal_pdf below for whole arrays)."""
    hx, hy, hz = vx + lx, vy + ly, vz + lz
    hl = np.sqrt(hx * hx + hy * hy + hz * hz)
    nh = max((nx * hx + ny * hy + nz * hz) / hl, ZERO) if hl > F(1e-12) else ZERO
    nv = max(nx * vx + ny * vy + nz * vz, MIN_COS)
    a2 = a * a
    t = nh * nh * (a2 - ONE) + ONE
    return g1(nv, a) * (a2 * INV_PI / (t * t)) / (F(4.0) * nv)


# ---- whole arrays (the reference path tracer, rt/embree/reference.py) -------------------------
def unit(a):
    return a / np.maximum(np.linalg.norm(a, axis=1, keepdims=True), 1e-20)


def schlick(f0_rgb: np.ndarray, cos: np.ndarray) -> np.ndarray:
    k = 1.0 - np.clip(cos, 0.0, 1.0)
    return f0_rgb + (1.0 - f0_rgb) * (k**5)[:, None]


def smith_g1(cos: np.ndarray, a: np.ndarray) -> np.ndarray:
    cos = np.maximum(cos, float(MIN_COS))
    return 2.0 * cos / (cos + np.sqrt(a * a + (1.0 - a * a) * cos * cos))


def ggx_d(cos_nh: np.ndarray, a: np.ndarray) -> np.ndarray:
    """GGX's distribution of normals D (module notes)."""
    a2 = a * a
    t = np.maximum(cos_nh, 0.0) ** 2 * (a2 - 1.0) + 1.0
    return a2 / (np.pi * t * t)


def ggx_lobes(n: np.ndarray, v: np.ndarray, lt: np.ndarray, albedo, metallic, a) -> tuple[np.ndarray, np.ndarray]:
    """The two lobes of f(v, l) for whole arrays (N,3): diffuse c_diff (1 - F) / pi and specular
    F D V, as ggx_terms (unit n, v towards the viewer, l towards the light)."""
    f0_rgb = 0.04 * (1 - metallic[:, None]) + albedo * metallic[:, None]
    h = unit(v + lt)
    f = schlick(f0_rgb, np.einsum("ij,ij->i", v, h))
    nv = np.maximum(np.einsum("ij,ij->i", n, v), float(MIN_COS))
    nl = np.maximum(np.einsum("ij,ij->i", n, lt), float(MIN_COS))
    a2 = a * a
    vis = 1.0 / ((nv + np.sqrt(a2 + (1 - a2) * nv * nv)) * (nl + np.sqrt(a2 + (1 - a2) * nl * nl)))
    dv = ggx_d(np.einsum("ij,ij->i", n, h), a) * vis
    return albedo * (1 - metallic[:, None]) * (1 - f) / np.pi, f * dv[:, None]


def visible_normal_pdf(n: np.ndarray, v: np.ndarray, lt: np.ndarray, a: np.ndarray) -> np.ndarray:
    """The density per solid angle of direction l reflected about a normal drawn from GGX's
    visible normals (visible_normal): G1(v) D(h) / (4 n.v)."""
    h = unit(v + lt)
    nv = np.maximum(np.einsum("ij,ij->i", n, v), float(MIN_COS))
    return smith_g1(nv, a) * ggx_d(np.einsum("ij,ij->i", n, h), a) / (4 * nv)


@njit(cache=True, error_model="numpy", nogil=True, fastmath=True)
def visible_normals(N, V, A, U, out):
    """out[i] = visible_normal for point i (unit normal N[i], view V[i], alpha A[i], uniforms
    U[i, 0:2]): the reference path tracer's GGX samples, drawn as the reflections' glossy rays'."""
    for i in range(N.shape[0]):
        out[i, 0], out[i, 1], out[i, 2] = visible_normal(N[i, 0], N[i, 1], N[i, 2], V[i, 0], V[i, 1], V[i, 2], A[i],
                                                         U[i, 0], U[i, 1])
