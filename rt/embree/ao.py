"""Ray-traced ambient occlusion: cosine-weighted rays of length `radius`; AO is the fraction
that escape (1 = fully open)."""
from __future__ import annotations

import numpy as np

from rt.ao import AOPass
from rt.embree import blocks, gather, light_sampling, raygen
from rt.embree.jit import njit
from rt.embree.kernels import next_block


@njit(cache=True, error_model="numpy", nogil=True)
def ao_frame(counter, bounds, scene, frame, base, rays, radius, grey):
    """The whole AO pass in one call (scene, frame: kernel_args.SceneArgs, FrameArgs; base:
    RtFrame.key_base). One worker of the pass (Tracer.run_parallel runs one per thread), taking
    blocks of points (next_block on counter, bounds) until none is left; each block: for each of
    `rays` rays per point, a cosine-weighted ray of length `radius`, traced, counted if it
    escapes; then AO into the block's pixels, and the uncovered ones around them. Returns the
    rays it traced."""
    pix = frame.pix
    n = pix.shape[0]
    traced = 0
    while True:
        b0, b1 = next_block(counter, bounds)
        if b0 >= n:
            break
        keys = blocks.block_keys(pix, b0, b1, base)
        escaped = np.zeros(b1 - b0, np.float32)
        o, d, t, _, idx = light_sampling.no_rays()  # traced as they are made: none written out
        for r in range(rays):  # sample, trace, count: two random numbers per ray
            traced += raygen.hemisphere_live(frame.points, b0, keys, 2 * r, radius, (o, d, t, idx),
                                             frame.target, escaped.reshape((b1 - b0, 1)))
        gather.write_ao(frame.out, frame.aux, pix[b0:b1], escaped, rays, frame.albedo[b0:b1], grey)
        gather.fill_uncovered(frame.out, frame.aux, np.float32(1.0), pix, b0, b1, frame.view_dir, frame.env)
    return traced


def trace(rf) -> dict:
    """The AO pass over the frame's G-buffer (one compiled call): radiance, and rt_ao (the
    fraction of rays that escape) when asked."""
    out, ao_image = rf.frame_outputs(1, fill=1.0, name="rt_ao")
    p = AOPass.parameters(rf.options)
    rf.tracer.rays_traced += rf.tracer.run_parallel(
        ao_frame, len(rf.gb.index), rf.data.kernel_scene, rf.kernel_frame(out, ao_image), rf.key_base(AOPass.stream),
        p["rays"], np.float32(p["radius"]), p["greyscale"])
    return rf.outputs(out, rt_ao=ao_image)
