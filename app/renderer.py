"""The frame loop shared by the headless runner, the benchmark and the viewer:
scene -> G-buffer -> pass -> accumulation -> display. Dirty frames reset accumulation."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from app.camera import Camera
from app.frame import Frame
from app.options import Options
from app.passes import RT_PASSES, check_pass
from app.profiler import Profiler
from app.raster.channel_view import CHANNEL_VIEWS, ChannelViewPass, display_mapping
from app.raster.forward import ForwardLightingPass
from app.raster.gbuffer import GBufferPass
from app.raster.gbuffer_pack import GBufferPackPass
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


@dataclass
class Job:
    """One frame between prepare() and finish(); the CPU part runs in compute()."""

    frame: Frame
    state: tuple
    pass_name: str
    cpu: bool = False
    readback: dict | None = None
    result: dict | None = None


def rt_channel(rf, frame: Frame, channel: str) -> np.ndarray:
    """A G-buffer channel view from the CPU G-buffer (`gbuffer=rt`)."""
    gb, s = rf.gb, rf.gb.surface
    values = {"albedo": s.albedo, "normal": s.n, "position": s.p, "roughness": s.roughness[:, None],
              "emissive": s.emissive, "depth": gb.depth[gb.index][:, None]}
    if channel == "motion":
        clip = np.c_[s.p, np.ones(len(s))] @ frame.view_proj(frame.prev_camera).T
        ndc = clip[:, :2] / np.maximum(np.abs(clip[:, 3:4]), 1e-9) * np.sign(clip[:, 3:4])
        px_prev = (ndc * 0.5 + 0.5) * [frame.width, frame.height]
        y, x = np.divmod(gb.index, frame.width)
        px_now = np.stack([x + 0.5, frame.height - (y + 0.5)], 1)
        values["motion"] = np.c_[px_now - px_prev, np.zeros(len(s))]
    v = values[channel]
    return rf.full(np.broadcast_to(v, (len(s), 3)) if v.shape[1] == 1 else v)


class Renderer:
    def __init__(self, ctx, scene, options: Options | None = None, profiler: Profiler | None = None):
        self.ctx = ctx
        self.options = options or Options()
        self.profiler = profiler or Profiler()
        self.gbuffer = GBufferPass(ctx)
        self.gbuffer_pack = GBufferPackPass(ctx)
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
        self._rt_buffers: dict = {}  # the ray-traced passes' full-image outputs, reused (rt/frame.py)
        # a ray-traced pass's images besides radiance (rt_direct, rt_ao, ...: Pass.writes) are made
        # only if this is set (tests, scripts that read them from the pass); the display reads radiance
        self.pass_outputs = False

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
        """Render one frame synchronously (prepare on the GL thread, compute, finish)."""
        job = self.prepare(camera, width, height, pass_name)
        if job is None:
            return self.frame
        self.compute(job)
        return self.finish(job)

    def state_of(self, camera: Camera, width: int, height: int, pass_name: str) -> tuple:
        """Everything whose change makes a frame dirty (and resets accumulation)."""
        return (id(self.scene), camera.state(), width, height, pass_name, self.options.state(), self.seed)

    def prepare(self, camera: Camera, width: int, height: int, pass_name: str = "forward") -> Job | None:
        """GL work before the CPU part: G-buffer, raster passes. None: the last frame still holds."""
        check_pass(pass_name)
        state = self.state_of(camera, width, height, pass_name)
        max_frames = int(self.options.get("max_frames"))
        converged = bool(self.options.get("accumulate")) and max_frames and self.accumulation.count >= max_frames
        if (self.reuse_static_frames and state == self._state and self.frame is not None
                and (self.deterministic(pass_name) or converged)):
            return None  # nothing would change: show the last frame
        if state != self._state:
            self.accumulation.reset()
            self._state = state
        self.profiler.begin_frame()
        frame = Frame(self.ctx, self.scene, self.gpu, camera, self.prev_camera or camera, width, height, self.options,
                      self.profiler, self.environment(), self.accumulation.count, self.seed)
        job = Job(frame, state, pass_name)
        rt_gbuffer = self.options.get("gbuffer") == "rt"
        if pass_name == "forward":
            self.gbuffer.execute(frame)
            self._forward(frame)
        elif pass_name in CHANNEL_VIEWS and not rt_gbuffer:
            self.gbuffer.execute(frame)
            self.channel_view.execute(frame, pass_name)
        else:  # CPU work follows: keep what the G-buffer gives, trace later
            raster = pass_name == "hybrid" or not rt_gbuffer
            if raster:
                self.gbuffer.execute(frame)
                self.gbuffer_pack.execute(frame)
                with self.profiler.cpu("gbuffer_readback"):
                    job.readback = self.gbuffer_pack.read()
            self.ray_tracing()
            job.cpu = True
        return job

    def compute(self, job: Job) -> None:
        """The CPU part of a frame (ray tracing); safe to run on a worker thread."""
        if not job.cpu:
            return
        from rt.frame import RtFrame
        from rt.gbuffer import from_raster, trace_primary

        frame, rt = job.frame, self.ray_tracing()
        rays0 = rt.tracer.rays_traced
        if job.readback is not None:
            with self.profiler.cpu("gbuffer_unpack"):
                gb = from_raster(job.readback, frame.camera, frame.width, frame.height, reuse=True)
        else:
            with self.profiler.cpu("gbuffer_rt"):
                gb = trace_primary(rt.data, rt.tracer, frame.camera, frame.width, frame.height, reuse=True)
        rf = RtFrame(rt.data, rt.tracer, gb, frame.environment, self.options, self.seed, frame.index, self._rt_buffers,
                     aux=self.pass_outputs)
        if job.pass_name in CHANNEL_VIEWS:
            job.result = {"radiance": rt_channel(rf, frame, job.pass_name)}
        elif job.pass_name == "hybrid":
            from rt.hybrid import hybrid_components

            with self.profiler.cpu("hybrid_rt"):
                job.result = hybrid_components(rf)
        else:
            with self.profiler.cpu(job.pass_name):
                job.result = self.rt_passes[job.pass_name].execute(rf)
        self.profiler.count("rays", rt.tracer.rays_traced - rays0)

    def finish(self, job: Job) -> Frame:
        """GL work after the CPU part: uploads, accumulation, tone mapping."""
        frame = job.frame
        if job.cpu:
            if job.pass_name == "hybrid":
                textures = {name: self._upload(frame, name, img) for name, img in job.result.items()}
                self._forward(frame, textures)
            else:
                frame.channels["radiance"] = self._upload(frame, "radiance", job.result["radiance"])
        mapping = display_mapping(job.pass_name, self.scene, frame.camera) if job.pass_name in CHANNEL_VIEWS else None
        out = self.accumulation.execute(frame, frame.channels["radiance"], bool(self.options.get("accumulate")),
                                        int(self.options.get("max_frames")))
        fxaa = job.pass_name in ("forward", "hybrid") and self.options.get("forward.fxaa")
        self.display.execute(frame, out, self.options.get("exposure"), fxaa, mapping)
        self.prev_camera = frame.camera.copy()
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
        for p in (self.gbuffer, self.gbuffer_pack, self.shadow_maps, self.ssao, self.forward, self.channel_view,
                  self.accumulation, self.display, self.uploads):
            p.release()
        self.gpu.release()
        if self.rt is not None:
            self.rt.close()
