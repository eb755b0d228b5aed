"""Ray-traced shadows: a shadow ray to every light per pixel (`all`), or to one light per
pixel chosen by its contribution there (`one`, unbiased: accumulates to `all`); and where the
environment is not black one more towards it (env_light.py), its light in the image but not in
rt_direct (hybrid's forward shading has the environment's own ambient)."""
from __future__ import annotations

import numpy as np

from rt.embree import blocks, brdf, env_light, gather, light_sampling
from rt.embree.jit import njit
from rt.embree.kernels import next_block
from rt.shadows import ShadowsPass


@njit(cache=True, error_model="numpy", nogil=True)
def shadows_all(counter, bounds, scene, frame, base, grey, ggx):
    """The whole shadows pass in one call (scene, frame: kernel_args.SceneArgs, FrameArgs; base:
    RtFrame.key_base), a shadow ray to every light. One worker of the pass (Tracer.run_parallel
    runs one per thread), taking blocks of points (next_block on counter, bounds) until none is
    left; each block: sample a shadow ray to every light, trace it, add the light of those that
    get through (light_sampling.direct_all), then _finish. Returns the rays it traced."""
    pix = frame.pix
    traced = 0
    while True:
        b0, b1 = next_block(counter, bounds)
        if b0 >= pix.shape[0]:
            return traced
        irradiance = brdf.accumulator(ggx, frame.view_dir, pix[b0:b1], frame.roughness[b0:b1])
        keys = blocks.block_keys(pix, b0, b1, base)
        traced += light_sampling.direct_all(frame.points, b0, keys, scene.lights, 0, scene.far, frame.target,
                                            irradiance)
        traced += _finish(frame, scene, b0, b1, keys, irradiance, grey, ggx)


@njit(cache=True, error_model="numpy", nogil=True)
def shadows_one(counter, bounds, scene, frame, base, grey, ggx):
    """shadows_all with one shadow ray per point, to a light picked by its contribution there
    (light_sampling.direct_one). A kernel of its own, so that a frame compiles one light sampling."""
    pix = frame.pix
    traced = 0
    while True:
        b0, b1 = next_block(counter, bounds)
        if b0 >= pix.shape[0]:
            return traced
        irradiance = brdf.accumulator(ggx, frame.view_dir, pix[b0:b1], frame.roughness[b0:b1])
        keys = blocks.block_keys(pix, b0, b1, base)
        traced += light_sampling.direct_one(frame.points, b0, keys, scene.lights, 0, scene.far, frame.target,
                                            irradiance)
        traced += _finish(frame, scene, b0, b1, keys, irradiance, grey, ggx)


@njit(cache=True, error_model="numpy", nogil=True)
def _finish(frame, scene, b0, b1, keys, irradiance, grey, ggx):
    """A block's lights' irradiance into frame.aux (ggx: its direct radiance, brdf.py), then the
    environment's sample added (env_light.py), the block's pixels from the sum (grey: light
    alone), and the uncovered pixels around them. Returns the environment's rays traced."""
    pix = frame.pix
    albedo, metallic = frame.albedo[b0:b1], frame.metallic[b0:b1]
    if frame.aux.shape[0] > 0:
        gather.put_rows(frame.aux, pix[b0:b1],
                        gather.direct_radiance(irradiance, albedo, metallic) if ggx else irradiance)
    base = np.ones_like(albedo) if grey else albedo
    metal = np.zeros_like(metallic) if grey else metallic
    traced = env_light.env_shadow_rays(frame.points, b0, keys, env_light.env_dim(scene.lights[3]), frame.env,
                                       frame.env_dist, scene.far, frame.target, irradiance, base, metal)
    gather.write_lit(frame.out, frame.spec, pix[b0:b1], frame.emissive[b0:b1], albedo, metallic, irradiance, grey)
    gather.fill_uncovered(frame.out, frame.aux, np.float32(0.0), pix, b0, b1, frame.view_dir, frame.env)
    return traced


def trace(rf) -> dict:
    """The shadows pass over the frame's G-buffer (one compiled call): radiance, and rt_direct
    (irradiance x cos; with GGX the direct radiance) when asked."""
    out, direct = rf.frame_outputs(name="rt_direct")
    spec = rf.specular_image()
    p = ShadowsPass.parameters(rf.options)
    kernel = shadows_one if p["one"] else shadows_all
    rf.tracer.rays_traced += rf.tracer.run_parallel(
        kernel, len(rf.gb.index), rf.data.kernel_scene, rf.kernel_frame(out, direct, spec),
        rf.key_base(ShadowsPass.stream), p["greyscale"], rf.ggx)
    return rf.outputs(out, spec, rt_direct=direct)
