"""Serial, GIL-free kernels that consume traced rays inside a whole-frame kernel's block of
points: split hits from misses, gather what the hits need, and write the block's pixels into
the frame's images (and the uncovered pixels around them)."""
from __future__ import annotations

import numpy as np

from rt.embree import brdf
from rt.embree.brdf import ONE, ZERO, light_out
from rt.embree.jit import njit
from rt.embree.kernels import environment_rgb, environment_terms, uniform
from rt.embree.raygen import offset_origin
from rt.environment import env_args  # noqa: F401  (the kernels' callers read it from here)


@njit(cache=True, error_model="numpy", nogil=True, fastmath=True)
def split_hits(prim, m, dirs, owner, out, env_kind, env_color, horizon, zenith, ground, texels, sel):
    """sel[:k] = the rays j < m that hit something (returns k); a ray that missed adds the
    environment's radiance along dirs[j] to out[owner[j]] (kinds as env_args)."""
    terms = environment_terms(env_kind, env_color, horizon, zenith, ground)
    k = 0
    for j in range(m):
        hit = prim[j] >= 0
        sel[k] = j  # branch-free: kept by moving on
        k += hit
        if not hit and env_kind != 0:
            r, g, b = environment_rgb(dirs[j, 0], dirs[j, 1], dirs[j, 2], terms, texels)
            i = owner[j]
            out[i, 0] += r
            out[i, 1] += g
            out[i, 2] += b
    return k


@njit(cache=True, error_model="numpy", nogil=True)
def gather_keys(keys, owner, sel, k, out):
    """out[i] = keys[owner[sel[i]]]: the generators of the points that rays sel[:k] came from."""
    for i in range(k):
        out[i] = keys[owner[sel[i]]]


@njit(cache=True, error_model="numpy", nogil=True, fastmath=True)
def add_bounce(out, owner, sel, k, albedo, metallic, direct):
    """out[owner[sel[i]]] += the light leaving bounce hit i: its direct light's radiance
    (brdf.light_out; direct: its accumulator)."""
    for i in range(k):
        p = owner[sel[i]]
        for a in range(3):
            out[p, a] += light_out(direct, i, a, albedo[i, a], metallic[i])


@njit(cache=True, error_model="numpy", fastmath=True)
def _fill_run(out, aux, aux_fill, view_dir, terms, texels, p0, p1):
    channels = aux.shape[1] if aux.shape[0] > 0 else 0  # an empty aux: none (RtFrame.aux_image)
    for p in range(p0, p1):
        r, g, b = environment_rgb(view_dir[p, 0], view_dir[p, 1], view_dir[p, 2], terms, texels)
        out[p, 0], out[p, 1], out[p, 2] = r, g, b
        for a in range(channels):
            aux[p, a] = aux_fill


@njit(cache=True, error_model="numpy", nogil=True, fastmath=True)
def fill_uncovered(out, aux, aux_fill, pix, b0, b1, view_dir, env):
    """The pixels that no covered point of b0..b1 owns, in the run of the image from just
    after the previous block's last pixel to this block's last (to the image's end for the
    last block), so that a whole-frame kernel's blocks share out the whole image: out gets the
    environment's radiance (kinds as env_args), every channel of aux gets aux_fill (what
    RtFrame.background and RtFrame.image fill in, done here by the worker that writes the
    covered pixels around them, instead of two passes over the whole image before the frame;
    an empty aux gets nothing: RtFrame.aux_image)."""
    kind, color, horizon, zenith, ground, texels = env
    terms = environment_terms(kind, color, horizon, zenith, ground)
    n = pix.shape[0]
    p = pix[b0 - 1] + 1 if b0 > 0 else 0
    for j in range(b0, b1):
        q = pix[j]
        if q > p:  # a gap before this point (most points have none: no call for them)
            _fill_run(out, aux, aux_fill, view_dir, terms, texels, p, q)
        p = q + 1
    if b1 == n:
        _fill_run(out, aux, aux_fill, view_dir, terms, texels, p, out.shape[0])


@njit(cache=True, error_model="numpy", nogil=True)
def put_rows(image, pix, values):
    """image[pix[j]] = values[j] for a block's points, unless the image is empty (not asked for:
    RtFrame.aux_image)."""
    if image.shape[0] == 0:
        return
    for j in range(pix.shape[0]):
        p = pix[j]
        for a in range(values.shape[1]):
            image[p, a] = values[j, a]


@njit(cache=True, error_model="numpy", nogil=True, fastmath=True)
def write_lit(out, spec, pix, emissive, albedo, metallic, direct, grey):
    """out[pix[j]] = emissive + the direct light's radiance (brdf.light_out; direct: the light
    accumulator); grey: a white dielectric, no emission. spec (unless empty: not asked for)
    gets the specular lobe's part of it where the accumulator has GGX's sums (brdf.specular_out)."""
    split = spec.shape[0] > 0 and direct.shape[1] >= brdf.GGX_COLS
    for j in range(pix.shape[0]):
        p = pix[j]
        m = ZERO if grey else metallic[j]
        for a in range(3):
            base = ONE if grey else albedo[j, a]
            light = light_out(direct, j, a, base, m)
            out[p, a] = light if grey else emissive[j, a] + light
            if split:
                spec[p, a] = brdf.specular_out(direct, j, a, base, m)


@njit(cache=True, error_model="numpy", nogil=True, fastmath=True)
def write_gi(out, spec, pix, emissive, albedo, metallic, direct, indirect, outgoing, outgoing_spec, ggx):
    """The GI pass's out[pix[j]] = emissive + the direct light's radiance (brdf.light_out) + the
    indirect light leaving: with glTF's BRDF (ggx) outgoing[j], what the BRDF-sampled bounces
    (bounce.py) brought, else indirect[j] (incoming) x the albedo. With ggx, spec (unless empty)
    gets the specular lobe's part of both (brdf.specular_out, outgoing_spec)."""
    split = ggx and spec.shape[0] > 0
    for j in range(pix.shape[0]):
        p = pix[j]
        for a in range(3):
            light = light_out(direct, j, a, albedo[j, a], metallic[j])
            light += outgoing[j, a] if ggx else indirect[j, a] * albedo[j, a]
            out[p, a] = emissive[j, a] + light
            if split:
                spec[p, a] = brdf.specular_out(direct, j, a, albedo[j, a], metallic[j]) + outgoing_spec[j, a]


@njit(cache=True, error_model="numpy", nogil=True, fastmath=True)
def direct_radiance(direct, albedo, metallic):
    """The radiance (n, 3) that a GGX light accumulator gives (brdf.outgoing): what hybrid's
    rt_direct holds with GGX (with Lambert, the accumulator itself: irradiance x cos)."""
    n = direct.shape[0]
    out = np.empty((n, 3), np.float32)
    for j in range(n):
        for a in range(3):
            out[j, a] = light_out(direct, j, a, albedo[j, a], metallic[j])
    return out


@njit(cache=True, error_model="numpy", nogil=True, fastmath=True)
def write_ao(out, ao_image, pix, open_count, rays, albedo, grey):
    """AO = open_count / rays into ao_image (unless it is empty: RtFrame.aux_image), and AO
    (x albedo unless grey) into out."""
    inv = np.float32(1.0) / np.float32(rays)
    keep = ao_image.shape[0] > 0
    for j in range(pix.shape[0]):
        p = pix[j]
        v = open_count[j] * inv
        if keep:
            ao_image[p, 0] = v
        for a in range(3):
            out[p, a] = v if grey else albedo[j, a] * v


@njit(cache=True, error_model="numpy", fastmath=True)
def _fresnel(albedo, metallic, nx, ny, nz, vx, vy, vz, a):
    """Schlick's Fresnel, channel a: F0 = 0.04 for dielectrics, the albedo for metals."""
    f0 = np.float32(0.04) * (np.float32(1.0) - metallic) + albedo * metallic
    c = min(max(-(nx * vx + ny * vy + nz * vz), np.float32(0.0)), np.float32(1.0))
    return f0 + (np.float32(1.0) - f0) * (np.float32(1.0) - c) ** 5


@njit(cache=True, error_model="numpy", nogil=True, fastmath=True)
def mirror_rays(P, N, NG, V, sel, origin, direction):
    """For the points sel[k], seen along V[k]: the mirror direction about the shading normal
    (about the face normal where that would enter the surface), from an origin nudged to that
    side; ray k."""
    for k in range(sel.shape[0]):
        i = sel[k]
        vx, vy, vz = V[k, 0], V[k, 1], V[k, 2]
        c = 2 * (vx * N[i, 0] + vy * N[i, 1] + vz * N[i, 2])
        rx, ry, rz = vx - c * N[i, 0], vy - c * N[i, 1], vz - c * N[i, 2]
        if rx * NG[i, 0] + ry * NG[i, 1] + rz * NG[i, 2] <= 0:
            c = 2 * (vx * NG[i, 0] + vy * NG[i, 1] + vz * NG[i, 2])
            rx, ry, rz = vx - c * NG[i, 0], vy - c * NG[i, 1], vz - c * NG[i, 2]
        direction[k, 0], direction[k, 1], direction[k, 2] = rx, ry, rz
        side = np.float32(-1.0) if NG[i, 0] * rx + NG[i, 1] * ry + NG[i, 2] * rz < 0 else np.float32(1.0)
        origin[k, 0], origin[k, 1], origin[k, 2] = offset_origin(P[i, 0], P[i, 1], P[i, 2], side * NG[i, 0],
                                                                 side * NG[i, 1], side * NG[i, 2])


@njit(cache=True, error_model="numpy", nogil=True, fastmath=True)
def add_hit_colour(out, sel, k, emissive, albedo, metallic, direct, lit):
    """out[sel[i]] += emission + (the direct light's radiance, brdf.light_out, or the albedo
    unlit) at hit i."""
    for i in range(k):
        p = sel[i]
        for a in range(3):
            out[p, a] += emissive[i, a] + (light_out(direct, i, a, albedo[i, a], metallic[i]) if lit else albedo[i, a])


@njit(cache=True, error_model="numpy", nogil=True, fastmath=True)
def blend_mirror(colour, sel, emissive, albedo, metallic, N, V, inner, reflection, ggx, spec=None):
    """At the points sel[k]: colour = emission + (1 - F) (colour - emission) + F x inner, with
    Schlick's F for view directions V (ggx: colour += F x inner, the colour's light having its
    own Fresnel split, rt/embree/brdf.py, and spec += F x inner where spec is given: the
    specular part); reflection[sel[k]] = (inner, 1) when given."""
    for k in range(sel.shape[0]):
        i = sel[k]
        for a in range(3):
            f = _fresnel(albedo[i, a], metallic[i], N[i, 0], N[i, 1], N[i, 2], V[k, 0], V[k, 1], V[k, 2], a)
            e = emissive[i, a]
            if ggx:
                colour[i, a] += f * inner[k, a]
                if spec is not None:
                    spec[i, a] += f * inner[k, a]
            else:
                colour[i, a] = e + (np.float32(1.0) - f) * (colour[i, a] - e) + f * inner[k, a]
        if reflection is not None:
            reflection[i, 0], reflection[i, 1], reflection[i, 2], reflection[i, 3] = (
                inner[k, 0], inner[k, 1], inner[k, 2], np.float32(1.0))


@njit(cache=True, error_model="numpy", nogil=True, fastmath=True)
def glossy_ray(p, n, ng, view, albedo, metallic, roughness, key, origin, direction, weight):
    """A ray from point p (shading normal n, true normal ng) seen along `view` into its GGX lobe:
    a visible normal m (brdf.visible_normal, numbers brdf.GLOSSY_DIM + 0, 1), direction
    l = reflect(-v, m) and weight F(v.m) G1(l) per channel, 0 where l leaves below the surface."""
    vx, vy, vz = -view[0], -view[1], -view[2]
    a = brdf.alpha(roughness)
    mx, my, mz = brdf.visible_normal(n[0], n[1], n[2], vx, vy, vz, a, uniform(key, brdf.GLOSSY_DIM),
                                     uniform(key, brdf.GLOSSY_DIM + 1))
    vm = vx * mx + vy * my + vz * mz
    lx, ly, lz = 2 * vm * mx - vx, 2 * vm * my - vy, 2 * vm * mz - vz
    direction[0], direction[1], direction[2] = lx, ly, lz
    origin[0], origin[1], origin[2] = offset_origin(p[0], p[1], p[2], ng[0], ng[1], ng[2])
    nl = n[0] * lx + n[1] * ly + n[2] * lz
    if nl > ZERO and ng[0] * lx + ng[1] * ly + ng[2] * lz > ZERO:
        g = brdf.g1(nl, a)
        k = ONE - min(max(vm, ZERO), ONE)
        w = k * k * k * k * k
        for c in range(3):
            f0 = brdf.f0(albedo[c], metallic)
            weight[c] = (f0 + (ONE - f0) * w) * g
