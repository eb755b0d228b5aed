"""Compiled per-point kernels (numba, parallel over points) for light sampling, ray set-up
and hit shading: the work between Embree calls. NumPy versions of the same maths would
allocate a temporary per operation; these loop once per point and write into flat arrays.

Conventions are those of rt/shading.py (which documents them); the kernels are its engine.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

TWO_PI = 2.0 * math.pi
GOLDEN = np.uint64(0x9E3779B97F4A7C15)
M1 = np.uint64(0xBF58476D1CE4E5B9)
M2 = np.uint64(0x94D049BB133111EB)


@njit(cache=True)
def mix64(x):
    """splitmix64 finaliser."""
    x = (x ^ (x >> np.uint64(30))) * M1
    x = (x ^ (x >> np.uint64(27))) * M2
    return x ^ (x >> np.uint64(31))


@njit(cache=True)
def uniform(key, dim):
    """The uniform number [0,1) of one pixel's key in one dimension."""
    h = mix64(key + (np.uint64(dim) + np.uint64(1)) * GOLDEN)
    return np.float32(h >> np.uint64(40)) * np.float32(1.0 / 16777216.0)


@njit(cache=True, parallel=True, fastmath=True)
def uniforms(keys, dim0, k, out):
    for i in prange(keys.shape[0]):
        for j in range(k):
            out[i, j] = uniform(keys[i], dim0 + j)


@njit(cache=True)
def _basis(nx, ny, nz):
    sign = 1.0 if nz >= 0 else -1.0
    a = -1.0 / (sign + nz)
    b = nx * ny * a
    return (1 + sign * nx * nx * a, sign * b, -sign * nx), (b, sign + ny * ny * a, -ny)


@njit(cache=True)
def _offset_scale(eps, px, py, pz):
    return eps * (1.0 + max(abs(px), abs(py), abs(pz)) * 1e-3)


@njit(cache=True, inline="always", fastmath=True)
def _sample_analytic(k, px, py, pz, u0, u1, kind, lpos, ldir, lrad, cos_out, cos_in, ang, far):
    """Point, spot or sun light k: (dir, dist, irradiance on a surface facing the light)."""
    kd = kind[k]
    if kd == 2:  # sun, optionally a disc of angular radius ang
        ax, ay, az = -ldir[k, 0], -ldir[k, 1], -ldir[k, 2]
        r = ang[k]
        if r > 0:
            ct = 1.0 - u0 * (1.0 - math.cos(r))
            st = math.sqrt(max(0.0, 1.0 - ct * ct))
            phi = TWO_PI * u1
            t, b = _basis(ax, ay, az)
            cx, sy = st * math.cos(phi), st * math.sin(phi)
            dx = t[0] * cx + b[0] * sy + ax * ct
            dy = t[1] * cx + b[1] * sy + ay * ct
            dz = t[2] * cx + b[2] * sy + az * ct
        else:
            dx, dy, dz = ax, ay, az
        return dx, dy, dz, far, lrad[k, 0], lrad[k, 1], lrad[k, 2]
    vx, vy, vz = lpos[k, 0] - px, lpos[k, 1] - py, lpos[k, 2] - pz
    d2 = max(vx * vx + vy * vy + vz * vz, 1e-12)
    dist = math.sqrt(d2)
    dx, dy, dz = vx / dist, vy / dist, vz / dist
    att = 1.0 / d2
    if kd == 1:  # spot: glTF's squared linear ramp
        cd = -(dx * ldir[k, 0] + dy * ldir[k, 1] + dz * ldir[k, 2])
        t = min(max((cd - cos_out[k]) / max(cos_in[k] - cos_out[k], 1e-3), 0.0), 1.0)
        att *= t * t
    return dx, dy, dz, dist, lrad[k, 0] * att, lrad[k, 1] * att, lrad[k, 2] * att


@njit(cache=True, inline="always", fastmath=True)
def _sample_cluster(lo, hi, px, py, pz, u0, u1, u2, c_tri, c_keep, c_alias, c_pmf, c_le, c_double, positions,
                    indices, face_normals, tri_area):
    """A point on one of the cluster's triangles (alias method: O(1), branch-free), as
    (dir, dist short of the emitter, Le x cos_light / d^2 / pdf_area)."""
    x = u0 * (hi - lo)
    slot = min(int(x), hi - lo - 1)
    j = lo + slot
    j = j if (x - slot) < c_keep[j] else lo + c_alias[j]
    tri = c_tri[j]
    su = math.sqrt(u1)
    b0, b1, b2 = 1.0 - su, su * (1.0 - u2), su * u2
    i0, i1, i2 = indices[tri, 0], indices[tri, 1], indices[tri, 2]
    vx = positions[i0, 0] * b0 + positions[i1, 0] * b1 + positions[i2, 0] * b2 - px
    vy = positions[i0, 1] * b0 + positions[i1, 1] * b1 + positions[i2, 1] * b2 - py
    vz = positions[i0, 2] * b0 + positions[i1, 2] * b1 + positions[i2, 2] * b2 - pz
    d2 = max(vx * vx + vy * vy + vz * vz, 1e-12)
    inv = 1.0 / math.sqrt(d2)
    dx, dy, dz = vx * inv, vy * inv, vz * inv
    cl = -(face_normals[tri, 0] * dx + face_normals[tri, 1] * dy + face_normals[tri, 2] * dz)
    cl = abs(cl) if c_double[j] else max(cl, 0.0)
    g = cl / d2 * tri_area[tri] / c_pmf[j]
    return dx, dy, dz, d2 * inv * (1.0 - 1e-4), c_le[j, 0] * g, c_le[j, 1] * g, c_le[j, 2] * g


@njit(cache=True, inline="always", fastmath=True)
def _facing(nx, ny, nz, gx, gy, gz, dx, dy, dz):
    """cos between shading normal and light, 0 where the light is behind either normal."""
    cs = nx * dx + ny * dy + nz * dz
    return cs if (cs > 0.0 and gx * dx + gy * dy + gz * dz > 0.0) else 0.0


@njit(cache=True, inline="always", fastmath=True)
def _sample_light(k, px, py, pz, nx, ny, nz, gx, gy, gz, u0, u1, u2, lights, far):
    """One sample of light k seen from a point: (dir, dist, irradiance x cos) or e = 0."""
    (kind, lpos, ldir, lrad, cos_out, cos_in, ang, c_start, c_tri, c_keep, c_alias, c_pmf, c_le, c_double,
     positions, indices, face_normals, tri_area, count_analytic) = lights
    if k < count_analytic:
        dx, dy, dz, dist, ex, ey, ez = _sample_analytic(k, px, py, pz, u0, u1, kind, lpos, ldir, lrad, cos_out,
                                                        cos_in, ang, far)
    else:
        c = k - count_analytic
        dx, dy, dz, dist, ex, ey, ez = _sample_cluster(c_start[c], c_start[c + 1], px, py, pz, u0, u1, u2, c_tri,
                                                       c_keep, c_alias, c_pmf, c_le, c_double, positions, indices,
                                                       face_normals, tri_area)
    cs = _facing(nx, ny, nz, gx, gy, gz, dx, dy, dz)
    return dx, dy, dz, dist, ex * cs, ey * cs, ez * cs


@njit(cache=True, inline="always", fastmath=True)
def _write_ray(i, P, NG, eps, dx, dy, dz, dist, ex, ey, ez, origin, direction, tmax, e):
    s = _offset_scale(eps, P[i, 0], P[i, 1], P[i, 2])
    origin[i, 0] = P[i, 0] + NG[i, 0] * s
    origin[i, 1] = P[i, 1] + NG[i, 1] * s
    origin[i, 2] = P[i, 2] + NG[i, 2] * s
    direction[i, 0], direction[i, 1], direction[i, 2] = dx, dy, dz
    tmax[i] = max(dist - 2 * s, s)
    e[i, 0], e[i, 1], e[i, 2] = ex, ey, ez


@njit(cache=True, parallel=True, fastmath=True)
def analytic_rays(k, P, N, NG, keys, dim, kind, lpos, ldir, lrad, cos_out, cos_in, ang, eps, far, origin,
                  direction, tmax, e):
    """Shadow rays towards analytic light k for every point, with unshadowed irradiance x cos."""
    for i in prange(P.shape[0]):
        key = keys[i]
        dx, dy, dz, dist, ex, ey, ez = _sample_analytic(k, P[i, 0], P[i, 1], P[i, 2], uniform(key, dim),
                                                        uniform(key, dim + 1), kind, lpos, ldir, lrad, cos_out,
                                                        cos_in, ang, far)
        cs = _facing(N[i, 0], N[i, 1], N[i, 2], NG[i, 0], NG[i, 1], NG[i, 2], dx, dy, dz)
        _write_ray(i, P, NG, eps, dx, dy, dz, dist, ex * cs, ey * cs, ez * cs, origin, direction, tmax, e)


@njit(cache=True, parallel=True, fastmath=True)
def cluster_rays(lo, hi, P, N, NG, keys, dim, c_tri, c_keep, c_alias, c_pmf, c_le, c_double, positions, indices,
                 face_normals, tri_area, eps, origin, direction, tmax, e):
    """Shadow rays towards one emissive cluster for every point, with unshadowed irradiance x cos."""
    for i in prange(P.shape[0]):
        key = keys[i]
        dx, dy, dz, dist, ex, ey, ez = _sample_cluster(lo, hi, P[i, 0], P[i, 1], P[i, 2], uniform(key, dim),
                                                       uniform(key, dim + 1), uniform(key, dim + 2), c_tri, c_keep,
                                                       c_alias, c_pmf, c_le, c_double, positions, indices,
                                                       face_normals, tri_area)
        cs = _facing(N[i, 0], N[i, 1], N[i, 2], NG[i, 0], NG[i, 1], NG[i, 2], dx, dy, dz)
        _write_ray(i, P, NG, eps, dx, dy, dz, dist, ex * cs, ey * cs, ez * cs, origin, direction, tmax, e)


@njit(cache=True, parallel=True, fastmath=True)
def one_light_rays(P, N, NG, keys, dim, lights, cluster_centre, cluster_radius, cluster_power, eps, far,
                   origin, direction, tmax, e):
    """One light per point, picked with probability ~ an estimate of its contribution there
    (exact for analytic lights, a bounding-sphere bound for emissive clusters, never zero where
    the light could contribute), sampled and divided by that probability: unbiased."""
    count_analytic = lights[-1]
    kind, lpos, ldir, lrad, cos_out, cos_in = lights[0], lights[1], lights[2], lights[3], lights[4], lights[5]
    n_lights = count_analytic + cluster_centre.shape[0]
    for i in prange(P.shape[0]):
        px, py, pz = P[i, 0], P[i, 1], P[i, 2]
        nx, ny, nz = N[i, 0], N[i, 1], N[i, 2]
        w = np.empty(n_lights)
        total = 0.0
        for k in range(n_lights):
            if k < count_analytic:
                kd = kind[k]
                lum = 0.2126 * lrad[k, 0] + 0.7152 * lrad[k, 1] + 0.0722 * lrad[k, 2]
                if kd == 2:
                    c = -(nx * ldir[k, 0] + ny * ldir[k, 1] + nz * ldir[k, 2])
                    wk = lum * max(c, 0.0) + 1e-6 * lum
                else:
                    vx, vy, vz = lpos[k, 0] - px, lpos[k, 1] - py, lpos[k, 2] - pz
                    d2 = max(vx * vx + vy * vy + vz * vz, 1e-12)
                    c = (nx * vx + ny * vy + nz * vz) / math.sqrt(d2)
                    att = 1.0
                    if kd == 1:
                        d = math.sqrt(d2)
                        cd = -(vx * ldir[k, 0] + vy * ldir[k, 1] + vz * ldir[k, 2]) / d
                        t = min(max((cd - cos_out[k]) / max(cos_in[k] - cos_out[k], 1e-3), 0.0), 1.0)
                        att = t * t
                    wk = lum * att * max(c, 0.0) / d2
            else:
                j = k - count_analytic
                vx = cluster_centre[j, 0] - px
                vy = cluster_centre[j, 1] - py
                vz = cluster_centre[j, 2] - pz
                d2 = vx * vx + vy * vy + vz * vz
                d = math.sqrt(max(d2, 1e-12))
                r = cluster_radius[j]
                c = (nx * vx + ny * vy + nz * vz) / d
                # the cosine bound grows with the cluster's angular size, so no part is ever missed
                sin_r = min(r / d, 1.0)
                cb = min(max(c + sin_r, 0.0), 1.0) if sin_r < 1.0 else 1.0
                wk = cluster_power[j] * max(cb, 0.02) / max(d2 - r * r, r * r * 0.25 + 1e-12)
            w[k] = wk
            total += wk
        if total <= 0.0:
            _write_ray(i, P, NG, eps, 0.0, 1.0, 0.0, 1.0, 0.0, 0.0, 0.0, origin, direction, tmax, e)
            continue
        key = keys[i]
        target = uniform(key, dim) * total
        k = 0
        acc = w[0]
        while acc < target and k < n_lights - 1:
            k += 1
            acc += w[k]
        while w[k] <= 0.0 and k > 0:
            k -= 1
        prob = w[k] / total
        dx, dy, dz, dist, ex, ey, ez = _sample_light(k, px, py, pz, nx, ny, nz, NG[i, 0], NG[i, 1], NG[i, 2],
                                                     uniform(key, dim + 1), uniform(key, dim + 2),
                                                     uniform(key, dim + 3), lights, far)
        inv = 1.0 / prob if prob > 0 else 0.0
        _write_ray(i, P, NG, eps, dx, dy, dz, dist, ex * inv, ey * inv, ez * inv, origin, direction, tmax, e)


@njit(cache=True, parallel=True, fastmath=True)
def hemisphere_rays(P, N, NG, keys, dim, eps, origin, direction, valid):
    """Cosine-weighted directions about N, origins nudged off the surface; invalid below NG."""
    for i in prange(P.shape[0]):
        nx, ny, nz = N[i, 0], N[i, 1], N[i, 2]
        u0, u1 = uniform(keys[i], dim), uniform(keys[i], dim + 1)
        r = math.sqrt(u0)
        phi = TWO_PI * u1
        x, y = r * math.cos(phi), r * math.sin(phi)
        z = math.sqrt(max(0.0, 1.0 - u0))
        # orthonormal basis about n (Duff et al. 2017), written out so it stays inline
        sign = 1.0 if nz >= 0 else -1.0
        a = -1.0 / (sign + nz)
        b = nx * ny * a
        dx = (1 + sign * nx * nx * a) * x + b * y + nx * z
        dy = sign * b * x + (sign + ny * ny * a) * y + ny * z
        dz = -sign * nx * x - ny * y + nz * z
        direction[i, 0], direction[i, 1], direction[i, 2] = dx, dy, dz
        s = _offset_scale(eps, P[i, 0], P[i, 1], P[i, 2])
        origin[i, 0] = P[i, 0] + NG[i, 0] * s
        origin[i, 1] = P[i, 1] + NG[i, 1] * s
        origin[i, 2] = P[i, 2] + NG[i, 2] * s
        valid[i] = NG[i, 0] * dx + NG[i, 1] * dy + NG[i, 2] * dz > 0.0


@njit(cache=True, parallel=True, fastmath=True)
def shade_hits(prim, bu, bv, t, O, D, positions, normals, uvs, indices, material_ids, face_normals, base_color,
               roughness, metallic, emissive, tex_offset, tex_w, tex_h, tex_data,
               P, N, NG, albedo, rough, metal, emis):
    """Surface data at ray hits: position, normals facing the ray, textured albedo, material."""
    for i in prange(prim.shape[0]):
        tri = prim[i]
        w1, w2 = bu[i], bv[i]
        w0 = 1.0 - w1 - w2
        for a in range(3):
            P[i, a] = O[i, a] + D[i, a] * t[i]
        gx, gy, gz = face_normals[tri, 0], face_normals[tri, 1], face_normals[tri, 2]
        if gx * D[i, 0] + gy * D[i, 1] + gz * D[i, 2] > 0:
            gx, gy, gz = -gx, -gy, -gz
        NG[i, 0], NG[i, 1], NG[i, 2] = gx, gy, gz
        i0, i1, i2 = indices[tri, 0], indices[tri, 1], indices[tri, 2]
        nx = w0 * normals[i0, 0] + w1 * normals[i1, 0] + w2 * normals[i2, 0]
        ny = w0 * normals[i0, 1] + w1 * normals[i1, 1] + w2 * normals[i2, 1]
        nz = w0 * normals[i0, 2] + w1 * normals[i1, 2] + w2 * normals[i2, 2]
        ln = math.sqrt(nx * nx + ny * ny + nz * nz)
        if ln < 1e-20:
            nx, ny, nz, ln = gx, gy, gz, 1.0
        nx, ny, nz = nx / ln, ny / ln, nz / ln
        if nx * gx + ny * gy + nz * gz < 0:
            nx, ny, nz = -nx, -ny, -nz
        N[i, 0], N[i, 1], N[i, 2] = nx, ny, nz
        m = material_ids[tri]
        off = tex_offset[m]
        if off >= 0:
            u = w0 * uvs[i0, 0] + w1 * uvs[i1, 0] + w2 * uvs[i2, 0]
            v = w0 * uvs[i0, 1] + w1 * uvs[i1, 1] + w2 * uvs[i2, 1]
            tw, th = tex_w[m], tex_h[m]
            x = u * tw - 0.5
            y = v * th - 0.5
            x0, y0 = math.floor(x), math.floor(y)
            fx, fy = x - x0, y - y0
            xa, ya = int(x0) % tw, int(y0) % th
            xb, yb = (xa + 1) % tw, (ya + 1) % th
            for a in range(3):
                top = tex_data[off + ya * tw + xa, a] * (1 - fx) + tex_data[off + ya * tw + xb, a] * fx
                bot = tex_data[off + yb * tw + xa, a] * (1 - fx) + tex_data[off + yb * tw + xb, a] * fx
                albedo[i, a] = base_color[m, a] * (top * (1 - fy) + bot * fy)
        else:
            albedo[i, 0], albedo[i, 1], albedo[i, 2] = base_color[m, 0], base_color[m, 1], base_color[m, 2]
        rough[i] = roughness[m]
        metal[i] = metallic[m]
        emis[i, 0], emis[i, 1], emis[i, 2] = emissive[m, 0], emissive[m, 1], emissive[m, 2]


@njit(cache=True, nogil=True)
def compact(e, origin, direction, tmax):
    """Indices of rays that carry light, and their origin/direction/tmax packed in front."""
    n = e.shape[0]
    idx = np.empty(n, np.int64)
    m = 0
    for i in range(n):
        if e[i, 0] > 0 or e[i, 1] > 0 or e[i, 2] > 0:
            idx[m] = i
            if m != i:
                origin[m, 0], origin[m, 1], origin[m, 2] = origin[i, 0], origin[i, 1], origin[i, 2]
                direction[m, 0], direction[m, 1], direction[m, 2] = direction[i, 0], direction[i, 1], direction[i, 2]
                tmax[m] = tmax[i]
            m += 1
    return idx[:m]


@njit(cache=True, parallel=True, fastmath=True)
def add_unblocked(total, e, idx, blocked):
    for j in prange(idx.shape[0]):
        if not blocked[j]:
            i = idx[j]
            total[i, 0] += e[i, 0]
            total[i, 1] += e[i, 1]
            total[i, 2] += e[i, 2]


def alias_table(weights: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Walker's alias table: (keep probability, alias index) per slot, for O(1) sampling."""
    n = weights.size
    p = weights / weights.sum() * n
    keep = np.ones(n)
    alias = np.arange(n)
    small = [i for i in range(n) if p[i] < 1.0]
    large = [i for i in range(n) if p[i] >= 1.0]
    while small and large:
        s, g = small.pop(), large.pop()
        keep[s], alias[s] = p[s], g
        p[g] -= 1.0 - p[s]
        (small if p[g] < 1.0 else large).append(g)
    return keep, alias


@njit(cache=True)
def covered_pixels(face, height, width):
    """Top-row-first pixel ids whose G-buffer texel (bottom-row-first, as GL reads) is covered."""
    idx = np.empty(height * width, np.int64)
    m = 0
    for y in range(height):
        row = height - 1 - y
        for x in range(width):
            if face[row, x, 3] > 0:
                idx[m] = y * width + x
                m += 1
    return idx[:m]


@njit(cache=True, parallel=True, fastmath=True)
def unpack_gbuffer(pos, nrm, alb, emi, face, idx, eye, right, up, fwd, tan_half, aspect,
                   P, N, NG, albedo, rough, metal, emis, view_dir, depth):
    """GL's G-buffer textures (bottom row first) -> per-covered-pixel surface arrays and
    per-pixel view directions and depths, top row first."""
    height, width = pos.shape[0], pos.shape[1]
    for p in prange(height * width):
        y, x = p // width, p % width
        sx = ((x + 0.5) / width * 2.0 - 1.0) * tan_half * aspect
        sy = (1.0 - (y + 0.5) / height * 2.0) * tan_half
        dx = right[0] * sx + up[0] * sy + fwd[0]
        dy = right[1] * sx + up[1] * sy + fwd[1]
        dz = right[2] * sx + up[2] * sy + fwd[2]
        inv = 1.0 / math.sqrt(dx * dx + dy * dy + dz * dz)
        view_dir[p, 0], view_dir[p, 1], view_dir[p, 2] = dx * inv, dy * inv, dz * inv
        depth[p] = 0.0
    for j in prange(idx.shape[0]):
        p = idx[j]
        y, x = p // width, p % width
        r = height - 1 - y
        for a in range(3):
            P[j, a] = pos[r, x, a]
            albedo[j, a] = alb[r, x, a]
            emis[j, a] = emi[r, x, a]
        depth[p] = pos[r, x, 3]
        rough[j] = nrm[r, x, 3]
        metal[j] = alb[r, x, 3]
        ln = math.sqrt(nrm[r, x, 0] ** 2 + nrm[r, x, 1] ** 2 + nrm[r, x, 2] ** 2)
        ln = 1.0 / ln if ln > 1e-20 else 0.0
        N[j, 0], N[j, 1], N[j, 2] = nrm[r, x, 0] * ln, nrm[r, x, 1] * ln, nrm[r, x, 2] * ln
        ln = math.sqrt(face[r, x, 0] ** 2 + face[r, x, 1] ** 2 + face[r, x, 2] ** 2)
        ln = 1.0 / ln if ln > 1e-20 else 0.0
        NG[j, 0], NG[j, 1], NG[j, 2] = face[r, x, 0] * ln, face[r, x, 1] * ln, face[r, x, 2] * ln
        # the view direction through the surface point itself (exact for the raster G-buffer)
        vx, vy, vz = P[j, 0] - eye[0], P[j, 1] - eye[1], P[j, 2] - eye[2]
        ln = math.sqrt(vx * vx + vy * vy + vz * vz)
        if ln > 1e-20:
            view_dir[p, 0], view_dir[p, 1], view_dir[p, 2] = vx / ln, vy / ln, vz / ln


@njit(cache=True, parallel=True)
def pack_rgba_flipped(image, height, width, channels, out):
    """(H*W, C) top-row-first -> (H, W, 4) bottom-row-first for a GL texture upload."""
    for p in prange(height * width):
        y, x = p // width, p % width
        r = height - 1 - y
        for a in range(4):
            if a < channels:
                out[r, x, a] = image[p, a]
            elif channels == 1 and a < 3:
                out[r, x, a] = image[p, 0]
            else:
                out[r, x, a] = 1.0 if a == 3 else 0.0


@njit(cache=True, nogil=True)
def compact_valid(valid, origin, direction):
    """Indices of valid rays, with their origins and directions packed in front."""
    n = valid.shape[0]
    idx = np.empty(n, np.int64)
    m = 0
    for i in range(n):
        if valid[i]:
            idx[m] = i
            if m != i:
                origin[m, 0], origin[m, 1], origin[m, 2] = origin[i, 0], origin[i, 1], origin[i, 2]
                direction[m, 0], direction[m, 1], direction[m, 2] = direction[i, 0], direction[i, 1], direction[i, 2]
            m += 1
    return idx[:m]


@njit(cache=True, parallel=True)
def add_open(count, idx, blocked):
    for j in prange(idx.shape[0]):
        if not blocked[j]:
            count[idx[j]] += 1.0


@njit(cache=True, parallel=True)
def scatter_rows(out, idx, values):
    """out[idx[j]] = values[j] for (M,C) values."""
    for j in prange(idx.shape[0]):
        for a in range(values.shape[1]):
            out[idx[j], a] = values[j, a]


@njit(cache=True, parallel=True, fastmath=True)
def scatter_lit(out, idx, emissive, albedo, scale, light, extra):
    """out[idx[j]] = emissive + albedo * (scale * light + extra): diffuse shading into an image."""
    for j in prange(idx.shape[0]):
        i = idx[j]
        for a in range(3):
            out[i, a] = emissive[j, a] + albedo[j, a] * (scale * light[j, a] + extra[j, a])


# Serial, GIL-free twins of the ray kernels, for the tracer's chunk pipeline: each tracing thread
# generates, traces and consumes its own chunk, so set-up work runs in parallel with tracing.
# (Not cached: a cache entry per Python function would clash with the parallel twin's.)
def _serial(kernel):
    return njit(nogil=True, fastmath=True)(kernel.py_func)


analytic_rays_chunk = _serial(analytic_rays)
cluster_rays_chunk = _serial(cluster_rays)
one_light_rays_chunk = _serial(one_light_rays)
hemisphere_rays_chunk = _serial(hemisphere_rays)
add_unblocked_chunk = _serial(add_unblocked)
add_open_chunk = _serial(add_open)
