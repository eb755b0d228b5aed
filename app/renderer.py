"""The frame loop shared by the headless runner, the benchmark and the viewer:
scene -> G-buffer -> pass -> accumulation -> display. Dirty frames reset accumulation."""
from __future__ import annotations

import numpy as np

from app.camera import Camera
from app.frame import Frame
from app.options import Options
from app.passes import RT_PASSES, check_pass
from app.profiler import Profiler
from app.raster.channel_view import CHANNEL_VIEWS, ChannelViewPass, display_mapping
from app.raster.forward import ForwardLightingPass
from app.raster.gbuffer import GBufferPass
from app.raster.gpu_scene import GpuScene
from app.raster.lights import assign_shadow_slots, gather_lights
from app.raster.postprocess import AccumulationPass, DisplayPass
from app.raster.shadow_maps import ShadowMapPass
from app.raster.ssao import SSAOPass
from app.raster.upload import Uploads, read_rgba
from scenes.model import Environment


class RayTracing:
    """The scene's tracer and shading data, built on first use (the BVH build takes time)."""

    def __init__(self, scene):
        from rt.shading import SceneData
        from rt.tracer import EmbreeTracer

        self.data = SceneData(scene)
        self.tracer = EmbreeTracer(scene.positions, scene.indices)

    def close(self) -> None:
        self.tracer.close()


class Renderer:
    def __init__(self, ctx, scene, options: Options | None = None, profiler: Profiler | None = None):
        self.ctx = ctx
        self.options = options or Options()
        self.profiler = profiler or Profiler()
        self.gbuffer = GBufferPass(ctx)
        self.shadow_maps = ShadowMapPass(ctx)
        self.ssao = SSAOPass(ctx)
        self.forward = ForwardLightingPass(ctx)
        self.channel_view = ChannelViewPass(ctx)
        self.accumulation = AccumulationPass(ctx)
        self.display = DisplayPass(ctx)
        self.uploads = Uploads(ctx)
        self.rt_passes = RT_PASSES()
        self.gpu = None
        self.rt: RayTracing | None = None
        self.scene = None
        self.set_scene(scene)
        self._state = None
        self.prev_camera = None
        self.frame: Frame | None = None
        self.seed = 0
        # the viewer sets this: a deterministic (raster) frame whose inputs did not change is
        # shown again instead of re-rendered, which keeps the UI responsive on software GL
        self.reuse_static_frames = False

    def set_scene(self, scene) -> None:
        if self.gpu is not None:
            self.gpu.release()
        if self.rt is not None:
            self.rt.close()
            self.rt = None
        self.scene = scene
        self.gpu = GpuScene(self.ctx, scene)
        self._state = None
        for p in self.rt_passes.values():
            p.reset()

    def ray_tracing(self) -> RayTracing:
        if self.rt is None:
            with self.profiler.cpu("bvh_build"):
                self.rt = RayTracing(self.scene)
        return self.rt

    def environment(self) -> Environment:
        env = self.options.get("env")
        return self.scene.environment if env == "scene" else Environment.parse(env)

    @property
    def frame_count(self) -> int:
        return self.accumulation.count

    def reset(self) -> None:
        self._state = None

    def deterministic(self, pass_name: str) -> bool:
        return pass_name == "forward" or pass_name in CHANNEL_VIEWS

    def render(self, camera: Camera, width: int, height: int, pass_name: str = "forward") -> Frame:
        check_pass(pass_name)
        state = (id(self.scene), camera.state(), width, height, pass_name, self.options.state(), self.seed)
        if (self.reuse_static_frames and state == self._state and self.frame is not None
                and self.deterministic(pass_name)):
            return self.frame  # nothing would change
        if state != self._state:
            self.accumulation.reset()
            self._state = state
        self.profiler.begin_frame()
        frame = Frame(self.ctx, self.scene, self.gpu, camera, self.prev_camera or camera, width, height, self.options,
                      self.profiler, self.environment(), self.accumulation.count, self.seed)
        mapping = None
        rt_gbuffer = self.options.get("gbuffer") == "rt"
        if pass_name == "forward":
            self.gbuffer.execute(frame)
            self._forward(frame)
        elif pass_name == "hybrid":
            self.gbuffer.execute(frame)
            self._hybrid(frame)
        elif pass_name in CHANNEL_VIEWS:
            if rt_gbuffer:
                self._rt_channel_view(frame, pass_name)
            else:
                self.gbuffer.execute(frame)
                self.channel_view.execute(frame, pass_name)
            mapping = display_mapping(pass_name, self.scene, camera)
        else:
            rf = self._rt_frame(frame)
            rays0 = rf.tracer.rays_traced
            with self.profiler.cpu(pass_name):
                out = self.rt_passes[pass_name].execute(rf)
            self.profiler.count("rays", rf.tracer.rays_traced - rays0)
            frame.channels["radiance"] = self._upload(frame, "radiance", out["radiance"])
        out_tex = self.accumulation.execute(frame, frame.channels["radiance"], bool(self.options.get("accumulate")),
                                            int(self.options.get("max_frames")))
        fxaa = pass_name in ("forward", "hybrid") and self.options.get("forward.fxaa")
        self.display.execute(frame, out_tex, self.options.get("exposure"), fxaa, mapping)
        self.prev_camera = camera.copy()
        self.frame = frame
        return frame

    # -- raster ------------------------------------------------------------------------------
    def _forward(self, frame: Frame, rt_inputs: dict | None = None) -> None:
        opts = self.options.group("forward")
        rt_inputs = rt_inputs or {}
        lights = gather_lights(self.scene, self.gpu, opts.emissive_lights)
        maps = bool(opts.shadow_maps) and "rt_direct" not in rt_inputs  # RT shadows replace the maps
        budget = opts.point_shadow_budget if maps else 0
        slots = assign_shadow_slots(lights, frame.camera.eye, budget, self.scene.diagonal)
        info = self.shadow_maps.execute(frame, lights, slots, enabled=maps)
        if opts.ssao and "rt_ao" not in rt_inputs and "rt_indirect" not in rt_inputs:
            self.ssao.execute(frame)
        self.forward.execute(frame, lights, info, rt_inputs)

    def _hybrid(self, frame: Frame) -> None:
        from rt.hybrid import hybrid_components

        rf = self._rt_frame(frame, raster_done=True)
        rays0 = rf.tracer.rays_traced
        with self.profiler.cpu("hybrid_rt"):
            parts = hybrid_components(rf)
        self.profiler.count("rays", rf.tracer.rays_traced - rays0)
        textures = {name: self._upload(frame, name, img) for name, img in parts.items()}
        self._forward(frame, textures)

    # -- ray tracing ---------------------------------------------------------------------------
    def _rt_frame(self, frame: Frame, raster_done: bool = False):
        from rt.frame import RtFrame
        from rt.gbuffer import from_raster, trace_primary

        rt = self.ray_tracing()
        if self.options.get("gbuffer") == "rt" and not raster_done:
            rays0 = rt.tracer.rays_traced
            with self.profiler.cpu("gbuffer_rt"):
                gb = trace_primary(rt.data, rt.tracer, frame.camera, frame.width, frame.height)
            self.profiler.count("rays", rt.tracer.rays_traced - rays0)
        else:
            if not raster_done:
                self.gbuffer.execute(frame)
            with self.profiler.cpu("gbuffer_readback"):
                chans = {name: read_rgba(frame.channels[name]) for name in
                         ("g_position", "g_normal", "g_albedo", "g_emissive", "g_face")}
                gb = from_raster(chans, frame.camera, frame.width, frame.height)
        return RtFrame(rt.data, rt.tracer, gb, frame.environment, self.options, self.seed, frame.index)

    def _rt_channel_view(self, frame: Frame, channel: str) -> None:
        rf = self._rt_frame(frame)
        gb, s = rf.gb, rf.gb.surface
        values = {"albedo": s.albedo, "normal": s.n, "position": s.p, "roughness": s.roughness[:, None],
                  "emissive": s.emissive, "depth": gb.depth[gb.index][:, None]}
        if channel == "motion":
            prev = frame.prev_camera
            clip = np.c_[s.p, np.ones(len(s))] @ frame.view_proj(prev).T
            ndc = clip[:, :2] / np.maximum(np.abs(clip[:, 3:4]), 1e-9) * np.sign(clip[:, 3:4])
            px_prev = (ndc * 0.5 + 0.5) * [frame.width, frame.height]
            y, x = np.divmod(gb.index, frame.width)
            px_now = np.stack([x + 0.5, frame.height - (y + 0.5)], 1)
            values["motion"] = np.c_[px_now - px_prev, np.zeros(len(s))]
        v = values[channel]
        img = rf.full(np.broadcast_to(v, (len(s), 3)) if v.shape[1] == 1 else v)
        frame.channels["radiance"] = self._upload(frame, "radiance", img)

    def _upload(self, frame: Frame, name: str, image: np.ndarray):
        with self.profiler.cpu("upload"):
            return self.uploads.upload(name, image, frame.width, frame.height)

    # -- read back (row 0 = top of the image) ---------------------------------------------
    def read_display(self) -> np.ndarray:
        tex = self.frame.channels["display"]
        w, h = tex.size
        data = np.frombuffer(tex.read(), np.uint8).reshape(h, w, 4)
        return np.ascontiguousarray(data[::-1, :, :3])

    def read_linear(self) -> np.ndarray:
        return np.ascontiguousarray(read_rgba(self.frame.channels["accumulated"])[..., :3])

    def release(self) -> None:
        for p in (self.gbuffer, self.shadow_maps, self.ssao, self.forward, self.channel_view, self.accumulation,
                  self.display, self.uploads):
            p.release()
        self.gpu.release()
        if self.rt is not None:
            self.rt.close()
