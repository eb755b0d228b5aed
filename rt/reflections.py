"""Ray-traced reflections: where the G-buffer's roughness is below the threshold, trace the
mirror direction and shade the hit; Schlick's Fresnel blends the reflection with the local
colour. `lit=false` reproduces the study (hits show their material colour only)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit, prange

from app.options import opt, register_group
from rt import embree, gather, raygen, scratch
from rt.kernels import shade_hits
from rt.shading import INV_PI, direct_one, empty_surface

_shade_hits = shade_hits.serial  # inside a parallel kernel's blocks


@dataclass
class ReflectionsOptions:
    roughness_threshold: float = opt(0.3, "reflect on surfaces smoother than this", 0.0, 1.0)
    max_depth: int = opt(1, "mirror bounces (the study used 1)", 1, 16)
    lit: bool = opt(True, "shade hits with direct light and shadow rays (false: material colour, as the study)")


register_group("reflections", ReflectionsOptions)


def reflected_radiance(cf, s, sel, view, rng, depth: int, level: int = 0) -> np.ndarray:
    """Radiance arriving along the mirror directions at the points sel of s (viewed along
    `view`, one row per point of sel), following up to `depth` mirrors; a scratch buffer of
    this level. Every step runs even on no points, so each pixel draws the same numbers
    however the frame is chunked."""
    thr = cf.options.get("reflections.roughness_threshold")
    lit = cf.options.get("reflections.lit")
    m, name = sel.shape[0], f"refl{level}"
    out = scratch.buffer(name + ".out", (m, 3))
    out.fill(0)
    o, d, _, owner = scratch.rays(name, m)
    gather.mirror_rays(s.p, s.n, s.ng, view, sel, cf.data.eps, o, d)
    hits = cf.tracer.intersect(o[:m], d[:m])
    owner[:m] = np.arange(m)
    hit = scratch.buffer(name + ".hit", (m,), np.int64)
    k = gather.split_hits(hits.prim, m, d, owner, out, *gather.env_args(cf.environment), hit)
    hit = hit[:k]
    sh = cf.data.surface(hits, d, o, sel=hit, out=empty_surface(k, name + ".surface"))
    keys = scratch.buffer(name + ".keys", (k,), np.uint64)
    gather.gather_keys(rng.key, owner, hit, k, keys)  # rng: one generator per point of sel
    hrng = rng.with_keys(keys)
    direct = scratch.buffer(name + ".direct", (k, 3))
    if lit:
        direct_one(cf.data, cf.tracer, sh, hrng, out=direct)
    colour = scratch.buffer(name + ".colour", (k, 3))
    colour.fill(0)
    gather.add_hit_colour(colour, np.arange(k), k, sh.emissive, sh.albedo, direct, lit)
    if depth > 1:
        smooth = np.flatnonzero(sh.roughness < thr)
        inner = reflected_radiance(cf, sh, smooth, d[hit][smooth], hrng.subset(smooth), depth - 1, level + 1)
        gather.blend_mirror(colour, smooth, sh.emissive, sh.albedo, sh.metallic, sh.n, d[hit][smooth], inner, None)
    out[hit] = colour
    return out


def reflect(cf, reflection: np.ndarray | None = None) -> np.ndarray:
    """A chunk's colour with reflections blended in (without emission); the reflection itself
    goes into `reflection` as RGBA (alpha 1 where a reflection ray was traced), one row a point."""
    s = cf.s
    rng = cf.rng(3)
    local = scratch.buffer("refl.local", (len(s), 3))
    if cf.options.get("reflections.lit"):
        direct_one(cf.data, cf.tracer, s, rng, out=local)
        local *= s.albedo * INV_PI
    else:
        local[:] = s.albedo
    smooth = np.flatnonzero(s.roughness < cf.options.get("reflections.roughness_threshold"))
    view = cf.view[smooth]
    refl = reflected_radiance(cf, s, smooth, view, rng.subset(smooth), cf.options.get("reflections.max_depth"))
    zero = scratch.buffer("refl.zero", (len(s), 3))
    zero.fill(0)
    gather.blend_mirror(local, smooth, zero, s.albedo, s.metallic, s.n, view, refl, reflection)
    return local


@njit(cache=True, error_model="numpy", nogil=True, parallel=True)
def reflections_frame(workers, G, base, thr, lit, lights, eps, far, scene, env, mesh, pix, surface, view_dir, out,
                      reflection_image):
    """The whole reflections pass (one mirror bounce) in one call: blocks of points split among
    workers (raygen.next_block), each doing what a chunk does (the same numbers, in the same
    order): the local colour (lit: one chosen light, shadowed), a mirror ray from each point
    smoother than thr, its closest hit shaded (lit: with its own light sample), Fresnel's blend
    and the pixels written, with the uncovered ones around them (gather.fill_uncovered).
    Returns the rays traced. env: gather.env_args; mesh: what SceneData.surface shades hits
    with; surface: the G-buffer's (p, n, ng, albedo, roughness, metallic, emissive)."""
    n = pix.shape[0]
    # the loop body may not take tuples of arrays from outside (numba): unpacked here, rebuilt there
    kind, lpos, ldir, lrad, cos_out, spot_scale, cos_ang, lum = lights[0]
    start, rows, keep, alias = lights[1]
    lx, ly, lz, sx, sy, sz, glum, gcos, gscale, sun, cx, cy, cz, radius, power = lights[2]
    n_lights = lights[3]
    env_kind, env_color, horizon, zenith, ground = env
    corners, face_normals, base_color, roughness, metallic, emission, tex_offset, tex_w, tex_h, tex_data = mesh
    P, N, NG, albedo, rough, metal, emissive = surface
    size = raygen.block_size(n, workers)
    counter = np.zeros(1, np.int64)  # blocks taken (raygen.next_block)
    traced = np.zeros(workers, np.int64)  # by each worker (a scalar summed across this prange came out 0)
    for w in prange(workers):  # each takes blocks until none is left
        ls = ((kind, lpos, ldir, lrad, cos_out, spot_scale, cos_ang, lum), (start, rows, keep, alias),
              (lx, ly, lz, sx, sy, sz, glum, gcos, gscale, sun, cx, cy, cz, radius, power), n_lights)
        while True:
            b0, b1 = raygen.next_block(counter, n, size)
            if b0 >= n:
                break
            nb = b1 - b0
            kb = raygen.block_keys(pix, b0, b1, base)
            local = np.empty((nb, 3), np.float32)
            if lit:
                traced[w] += raygen.direct_block(G, b0, kb, ls, True, 0, eps, far, scene, local)
                for j in range(nb):
                    for a in range(3):
                        local[j, a] *= albedo[b0 + j, a] * INV_PI
            else:
                local[:] = albedo[b0:b1]
            smooth, near = np.empty(nb, np.int64), np.empty(nb, np.int64)  # frame rows, block rows
            m = 0
            for j in range(nb):
                if rough[b0 + j] < thr:
                    smooth[m], near[m] = b0 + j, j
                    m += 1
            V, o, d = np.empty((m, 3), np.float32), np.empty((m, 3), np.float32), np.empty((m, 3), np.float32)
            skeys, owner = np.empty(m, np.uint64), np.arange(m)
            for k in range(m):
                p = pix[smooth[k]]
                V[k, 0], V[k, 1], V[k, 2] = view_dir[p, 0], view_dir[p, 1], view_dir[p, 2]
                skeys[k] = kb[near[k]]
            gather.mirror_rays(P, N, NG, V, smooth[:m], eps, o, d)
            th, prim, u, v = (np.empty(m, np.float32), np.empty(m, np.int32), np.empty(m, np.float32),
                              np.empty(m, np.float32))
            embree.intersect(scene, o, d, np.full(m, embree.MISS_T, np.float32), th, prim, u, v)
            refl, hit = np.zeros((m, 3), np.float32), np.empty(m, np.int64)
            k = gather.split_hits(prim, m, d, owner, refl, env_kind, env_color, horizon, zenith, ground, hit)
            hits = hit[:k]
            HP, HN, HNG, halb, hemis = (np.empty((k, 3), np.float32), np.empty((k, 3), np.float32),
                                        np.empty((k, 3), np.float32), np.empty((k, 3), np.float32),
                                        np.empty((k, 3), np.float32))
            hrough, hmetal = np.empty(k, np.float32), np.empty(k, np.float32)
            _shade_hits(hits, prim, u, v, th, o, d, corners, face_normals, base_color, roughness, metallic,
                        emission, tex_offset, tex_w, tex_h, tex_data, HP, HN, HNG, halb, hrough, hmetal, hemis)
            hdirect = np.zeros((k, 3), np.float32)
            if lit:
                hkeys = np.empty(k, np.uint64)
                gather.gather_keys(skeys, owner, hits, k, hkeys)
                hg = np.empty((9, k), np.float32)
                raygen.surface_soa(HP, HN, HNG, hg)
                traced[w] += raygen.direct_block(hg, 0, hkeys, ls, True, 4, eps, far, scene, hdirect)
            traced[w] += m
            colour = np.zeros((k, 3), np.float32)
            gather.add_hit_colour(colour, np.arange(k), k, hemis, halb, hdirect, lit)
            for i in range(k):
                for a in range(3):
                    refl[hits[i], a] = colour[i, a]
            reflection = np.zeros((nb, 4), np.float32)
            gather.blend_mirror(local, near[:m], np.zeros((nb, 3), np.float32), albedo[b0:b1], metal[b0:b1],
                                N[b0:b1], V, refl, reflection)
            for j in range(nb):
                p = pix[b0 + j]
                for a in range(3):
                    out[p, a] = local[j, a] + emissive[b0 + j, a]
                for a in range(4):
                    reflection_image[p, a] = reflection[j, a]
            gather.fill_uncovered(out, reflection_image, np.float32(0.0), pix, b0, b1, view_dir,
                                  (env_kind, env_color, horizon, zenith, ground))
    return traced.sum()


class ReflectionsPass:
    name = "reflections"
    reads = ("gbuffer",)
    writes = ("radiance", "rt_reflection")

    def reset(self) -> None:
        pass

    def execute(self, rf) -> dict:
        scene = rf.tracer.frame_scene()
        if scene and rf.options.get("reflections.max_depth") == 1 and rf.gb.soa is not None:
            out, reflection_image = rf.frame_outputs(4)
            s, data = rf.gb.surface, rf.data  # one compiled call: no Python per chunk
            rf.tracer.rays_traced += rf.tracer.run_parallel(
                reflections_frame, rf.gb.soa, rf.key_base(3),
                np.float32(rf.options.get("reflections.roughness_threshold")), rf.options.get("reflections.lit"),
                data.lights.kernel_args, data.eps, data.far, scene, gather.env_args(rf.environment), data.mesh_args,
                rf.gb.index, (s.p, s.n, s.ng, s.albedo, s.roughness, s.metallic, s.emissive), rf.gb.view_dir, out,
                reflection_image)
            return {"radiance": out, "rt_reflection": reflection_image}

        out, reflection_image = rf.background(), rf.image(4)

        def work(cf):
            reflection = scratch.buffer("refl.rgba", (len(cf.s), 4))
            reflection.fill(0)
            local = reflect(cf, reflection)
            local += cf.s.emissive
            cf.put(out, local)
            cf.put(reflection_image, reflection)

        rf.for_chunks(work, streams=(3,))
        return {"radiance": out, "rt_reflection": reflection_image}
