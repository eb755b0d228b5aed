"""SVGF on the Slang device (rt/svgf.py's pass through Backend.svgf): the kernels of
shaders/rt/svgf.slang over the device's G-buffer and the effect's radiance, recorded with the
frame's other work, into buffers kept from frame to frame; the denoised image stays on the
device for present (accumulation and display) or the export to GL."""
from __future__ import annotations

import functools

import numpy as np

from rt.slang.flights import SLOTS
from rt.slang.images import Image
from rt.slang.pipeline import ComputePipeline, elapsed

FILE = "svgf.slang"


def view_rows(inputs, camera) -> tuple:
    """Rows 0, 1 and 3 of a camera's view-projection (no jitter): what svgf.slang's pixel_of
    needs of it."""
    m = inputs.view_projection(camera)
    return tuple(np.asarray(m[i], np.float32) for i in (0, 1, 3))


class DeviceSvgf:
    def __init__(self, backend):
        import slangpy as spy

        self.backend = backend
        self._kernels: dict = {}
        self.timers = [backend.device.create_query_pool(type=spy.QueryType.timestamp, count=2) for _ in range(SLOTS)]
        self.flip = 0  # which of the two resolved images is this frame's

    def _dispatch(self, name: str, copy: int, values: dict) -> None:
        """Kernel `name` over the image; each dispatch of a frame (copy: the a-trous iteration)
        has a root object of its own, so that no recorded dispatch shares another's fields."""
        key = (name, copy)
        if key not in self._kernels:
            self._kernels[key] = ComputePipeline(self.backend.device, name, FILE)
        inputs = self.backend.inputs
        self._kernels[key].dispatch(self.backend._encoding(), inputs.width, inputs.height, values)

    def run(self, radiance, run, specular=None):
        """radiance filtered as run (rt/svgf.py's SvgfFrame) says; with run.split and the
        radiance's specular part (specular: its device image), the diffuse and the specular
        parts each in a run of their own; the result's device image."""
        b = self.backend
        inputs = b.inputs
        n = inputs.width * inputs.height
        split = bool(run.split) and specular is not None
        result = b._buffer("svgf.result", 3 * n, 4)
        common = {"g_gbuffer": b.gbuffer, "g_width": inputs.width, "g_height": inputs.height,
                  "g_radiance": radiance.buffer, "g_result": result, "g_has_albedo": int(run.has_albedo),
                  "g_has_emission": int(run.has_emission), "g_split": int(split),
                  "g_spec": specular.buffer if split else result, "g_diffuse": self._buf("out")}
        flight = b._flights.current
        timer = self.timers[flight.slot]
        timer.reset()
        encoder = b._encoding()
        encoder.write_timestamp(timer, 0)
        out = self._filter(run, common, "svgf", 0)
        if split:
            out = self._filter(run, common, "svgf.spec", 1)
        if run.opts.resolve:
            mine, before = self._buf(f"resolved.{self.flip}"), self._buf(f"resolved.{self.flip ^ 1}")
            self._dispatch("svgf_resolve", 0, {**common, "g_color": out, "g_prev_color": before,
                                               "g_motion": self._buf("motion"), "g_out": mine,
                                               "g_has_history": int(run.resolved),
                                               "g_alpha": float(run.opts.resolve_alpha)})
            self.flip ^= 1
        encoder.write_timestamp(timer, 1)
        flight.timers["svgf"] = functools.partial(elapsed, timer)
        return Image(result, n, 3)

    def _buf(self, name: str):
        inputs = self.backend.inputs
        return self.backend._buffer(f"svgf.{name}", inputs.width * inputs.height, 16)

    def _filter(self, run, common: dict, prefix: str, signal: int):
        """One run over the lighting (signal 0: the diffuse part, or the whole where not split;
        1: the specular part, whose last iteration adds the diffuse run's g_diffuse), in buffers
        of its own (prefix); its last iteration's image (also written into g_result)."""
        b, inputs = self.backend, self.backend.inputs

        def buf(name: str):
            return b._buffer(f"{prefix}.{name}", inputs.width * inputs.height, 16)

        common = {**common, "g_signal": signal}
        temporal, moments, motion = buf("temporal"), buf("moments"), self._buf("motion")
        kept = {"g_prev_color": buf("history.color"), "g_prev_moments": buf("history.moments"),
                "g_prev_position": buf("history.position"), "g_prev_normal": buf("history.normal")}
        opts, copy = run.opts, 100 * signal  # each dispatch of a frame has its own root object
        cur, prev = view_rows(inputs, inputs.camera), view_rows(inputs, inputs.prev_camera)
        self._dispatch("svgf_temporal", copy, {
            **common, **kept, "g_motion": motion, "g_out": temporal, "g_out_moments": moments,
            "g_cur_x": cur[0], "g_cur_y": cur[1], "g_cur_w": cur[2], "g_prev_x": prev[0], "g_prev_y": prev[1],
            "g_prev_w": prev[2], "g_has_history": int(run.history), "g_alpha": float(opts.alpha),
            "g_moments_alpha": float(opts.moments_alpha)})
        variance = buf("variance")
        self._dispatch("svgf_variance", copy, {**common, "g_color": temporal, "g_moments": moments,
                                               "g_out": variance, "g_phi_normal": float(opts.phi_normal),
                                               "g_alpha": float(opts.alpha), "g_of_average": int(not opts.feedback)})
        source, out = variance, buf("out")
        iterations = run.iterations
        for i in range(iterations):
            last = i == iterations - 1
            target = out if last else buf("ping" if i % 2 == 0 else "pong")
            self._dispatch("svgf_atrous", copy + i, {
                **common, "g_color": source, "g_moments": moments, "g_out": target, "g_step": 1 << i,
                "g_phi_color": float(opts.phi_color), "g_phi_normal": float(opts.phi_normal),
                "g_phi_depth": float(opts.phi_depth), "g_remodulate": int(last)})
            source = target
            if i == 0:  # what the next frame reprojects: the temporal average (or the first iteration's)
                first = (variance if last else source) if opts.feedback else temporal
                self._dispatch("svgf_history", copy, {**common, **kept, "g_out": first, "g_color": temporal,
                                                      "g_moments": moments})
        return out
