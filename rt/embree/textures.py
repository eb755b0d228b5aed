"""Texture layers at hit points (rt/mesh.py's flat RGBA texel array, one run per material and
layer): bilinear samples with glTF's wrap modes, the alpha test that cuts masked surfaces
(every ray's hits go through it: rt/embree/alpha.py), and normal mapping."""
from __future__ import annotations

import math

from rt.embree.jit import njit
from rt.mesh import LAYER_BASE, LAYER_NORMAL

UV_LIMIT = 1e6  # texture coordinates are clamped to this before they become texel indices


@njit(cache=True, error_model="numpy")
def wrap_index(i, n, mode):
    """Texel index i of n under a wrap mode (scenes.model.WRAP_*: 0 repeat, 1 clamp, 2 mirror)."""
    if mode == 1:
        return min(max(i, 0), n - 1)
    if mode == 2:
        i = i % (2 * n)
        return i if i < n else 2 * n - 1 - i
    return i % n


@njit(cache=True, error_model="numpy")
def bilinear(off, tw, th, wu, wv, u, v):
    """The four texel rows (top-left, top-right, bottom-left, bottom-right) of a bilinear
    sample of the texture at tex_data[off:off + tw * th] (rows top first), and their weights."""
    u = min(max(u, -UV_LIMIT), UV_LIMIT)
    v = min(max(v, -UV_LIMIT), UV_LIMIT)
    x = u * tw - 0.5
    y = v * th - 0.5
    x0, y0 = math.floor(x), math.floor(y)
    fx, fy = x - x0, y - y0
    xa, xb = wrap_index(int(x0), tw, wu), wrap_index(int(x0) + 1, tw, wu)
    ya, yb = wrap_index(int(y0), th, wv), wrap_index(int(y0) + 1, th, wv)
    r0, r1 = off + ya * tw, off + yb * tw
    return (r0 + xa, r0 + xb, r1 + xa, r1 + xb,
            (1 - fx) * (1 - fy), fx * (1 - fy), (1 - fx) * fy, fx * fy)


@njit(cache=True, error_model="numpy")
def nearest(off, tw, th, wu, wv, u, v):
    """bilinear's rows and weights for the one texel (u, v) falls in (its weight 1)."""
    u = min(max(u, -UV_LIMIT), UV_LIMIT)
    v = min(max(v, -UV_LIMIT), UV_LIMIT)
    i = off + wrap_index(int(math.floor(v * th)), th, wv) * tw + wrap_index(int(math.floor(u * tw)), tw, wu)
    return (i, i, i, i, 1.0, 0.0, 0.0, 0.0)


@njit(cache=True, error_model="numpy")
def sample(tex_data, tex_offset, tex_w, tex_h, wrap, m, k, u, v):
    """RGBA of material m's layer k at (u, v), a layer it has (tex_offset[m, k] >= 0): bilinear,
    or the nearest texel (Material.nearest). A call of its own, made only where the layer is
    there: numba's inline="always" re-typed this at every call site, seconds each (issue 44)."""
    off = tex_offset[m, k]
    if wrap[m, 2]:
        i00, i01, i10, i11, w00, w01, w10, w11 = nearest(off, tex_w[m, k], tex_h[m, k], wrap[m, 0], wrap[m, 1], u, v)
    else:
        i00, i01, i10, i11, w00, w01, w10, w11 = bilinear(off, tex_w[m, k], tex_h[m, k], wrap[m, 0], wrap[m, 1], u, v)
    return (tex_data[i00, 0] * w00 + tex_data[i01, 0] * w01 + tex_data[i10, 0] * w10 + tex_data[i11, 0] * w11,
            tex_data[i00, 1] * w00 + tex_data[i01, 1] * w01 + tex_data[i10, 1] * w10 + tex_data[i11, 1] * w11,
            tex_data[i00, 2] * w00 + tex_data[i01, 2] * w01 + tex_data[i10, 2] * w10 + tex_data[i11, 2] * w11,
            tex_data[i00, 3] * w00 + tex_data[i01, 3] * w01 + tex_data[i10, 3] * w10 + tex_data[i11, 3] * w11)


@njit(cache=True, error_model="numpy")
def hit_uv(c, w1, w2):
    """The uv at barycentrics (w1, w2) of a triangle's corner row c (rt/mesh.py)."""
    w0 = 1.0 - w1 - w2
    return w0 * c[9] + w1 * c[11] + w2 * c[13], w0 * c[10] + w1 * c[12] + w2 * c[14]


@njit(cache=True, error_model="numpy")
def passes_alpha(corners, tex_offset, tex_w, tex_h, wrap, tex_data, cutoff, base_alpha, prim, w1, w2):
    """False where a masked material is cut away at this hit: alpha (base alpha x texture
    alpha) below its cutoff."""
    c = corners[prim]
    m = int(c[15])
    if cutoff[m] < 0.0:
        return True
    alpha = base_alpha[m]
    if tex_offset[m, LAYER_BASE] >= 0:
        u, v = hit_uv(c, w1, w2)
        alpha *= sample(tex_data, tex_offset, tex_w, tex_h, wrap, m, LAYER_BASE, u, v)[3]
    return alpha >= cutoff[m]


@njit(cache=True, error_model="numpy")
def normal_mapped(c, m, w0, w1, w2, nx, ny, nz, u, v, tex):
    """The shading normal (nx, ny, nz: the interpolated unit vertex normal) bent by material
    m's normal map (which it has: tex_offset[m, LAYER_NORMAL] >= 0) in the frame of the
    interpolated vertex tangents (row columns 16..27). tex: the texture layers (tex_offset,
    tex_w, tex_h, wrap, tex_data: SceneData.mesh_args')."""
    tex_offset, tex_w, tex_h, wrap, tex_data = tex
    if c.shape[0] < 28:
        return nx, ny, nz
    mx, my, mz, _ = sample(tex_data, tex_offset, tex_w, tex_h, wrap, m, LAYER_NORMAL, u, v)
    tx = w0 * c[16] + w1 * c[20] + w2 * c[24]
    ty = w0 * c[17] + w1 * c[21] + w2 * c[25]
    tz = w0 * c[18] + w1 * c[22] + w2 * c[26]
    handed = -1.0 if c[19] < 0 else 1.0
    d = tx * nx + ty * ny + tz * nz  # Gram-Schmidt against the normal
    tx, ty, tz = tx - d * nx, ty - d * ny, tz - d * nz
    lt = math.sqrt(tx * tx + ty * ty + tz * tz)
    if lt < 1e-12:
        return nx, ny, nz
    tx, ty, tz = tx / lt, ty / lt, tz / lt
    bx, by, bz = (ny * tz - nz * ty) * handed, (nz * tx - nx * tz) * handed, (nx * ty - ny * tx) * handed
    ox, oy, oz = tx * mx + bx * my + nx * mz, ty * mx + by * my + ny * mz, tz * mx + bz * my + nz * mz
    lo = math.sqrt(ox * ox + oy * oy + oz * oz)
    if lo < 1e-12:
        return nx, ny, nz
    return ox / lo, oy / lo, oz / lo
