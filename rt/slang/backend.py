"""The Slang backend behind rt.backend.Backend: the scene on a slangpy device (scene.py), the
frame's primary hits traced there (shaders/rt/primary.slang), and each effect as a ray-tracing
pipeline of its own shader file (shaders/rt/<effect>.slang). Images are device buffers until
to_host reads them back."""
from __future__ import annotations

import functools

import numpy as np

from core.errors import DeviceError, UserError
from rt.backend import Backend, FrameInputs
from rt.effects import AUX_CHANNEL, AUX_CHANNELS, PASSES, PLUGINS, STREAM
from rt.effects import EFFECTS as ALL_EFFECTS
from rt.environment import env_args, env_distribution
from rt.pass_base import SPECULAR
from rt.slang.device import SHADER_DIR, open_device
from rt.slang.flights import COUNTER_WORDS, Flights
from rt.slang.images import Image, Rgba8
from rt.slang.pipeline import ComputePipeline, Pipeline
from rt.slang.scene import DeviceScene
from rt.slang.svgf import DeviceSvgf

MISSES = ("hit_miss", "shadow_miss")  # shaders/rt/trace.slang: miss shader 0 and 1, and its closest hit
# an effect on the device is the shader file shaders/rt/<effect>.slang with the ray-generation
# entry point <effect>_rays (its random stream, own image and uniforms come from its record:
# rt/effects.py); the effects this backend traces are those with such a file


def shader_file(effect: str) -> str | None:
    """The effect's shader (an RTLAB_EFFECTS module's SLANG_SHADER, else shaders/rt/<effect>.slang),
    or None where it has none."""
    plugin = getattr(PLUGINS.get(effect), "SLANG_SHADER", None)
    if plugin is not None:
        return str(plugin)
    return f"{effect}.slang" if (SHADER_DIR / f"{effect}.slang").is_file() else None


EFFECTS = tuple(e for e in ALL_EFFECTS if shader_file(e) is not None)


def _key_words(base: np.uint64) -> tuple[int, int]:
    b = int(base)
    return b & 0xFFFFFFFF, b >> 32


def _device_errors(method):
    """slangpy's RuntimeErrors (a lost device, out of memory) as one line for the user."""

    @functools.wraps(method)
    def call(self, *args, **kwargs):
        try:
            return method(self, *args, **kwargs)
        except RuntimeError as e:
            raise DeviceError(f"the {self.name} device failed ({str(e).splitlines()[0][:160]}); "
                              f"ray tracing goes back to embree") from None

    return call


class SlangBackend(Backend):
    denoisers = ("svgf", "oidn")  # rt/slang/svgf.py; rt/slang/oidn.py where OIDN has a GPU device (on_device)

    def __init__(self, kind: str = "vulkan"):
        self.name = kind
        self.device = open_device(kind)  # imports slangpy (without PyTorch: rt/slang/device.py)
        self.scene: DeviceScene | None = None
        self.inputs: FrameInputs | None = None
        self._pipelines: dict = {}
        self._buffers: dict = {}  # name -> (buffer, size): reused from frame to frame
        self._staging: dict = {}  # host copies of the raster G-buffer, reused (_unpack)
        self._svgf = None  # DeviceSvgf, made on first use
        self._oidn = None  # DeviceOidn, made when first asked for (on_device)
        self.oidn_note: str | None = None  # why OIDN has no device here, once asked
        self._env_texels = None  # (the map's texels, their device buffer, its distribution's, its cells)
        self._encoder = None  # the work being recorded, submitted before the host reads or waits (_submit)
        self._recording = None  # (log buffer, capacity) while a frame's rays are recorded (record)
        self._submitted = None  # the id of the last submission
        self._log_count = self._buffer("log.count", 1, 4)
        self._counter = self._buffer("rays_traced", COUNTER_WORDS, 4)
        self._counter.copy_from_numpy(np.zeros(COUNTER_WORDS, np.uint32))
        # each frame's submission, ray count and timestamps, read when it is done
        self._flights = Flights(self.device, kind, self._counter, self.cuda_context() if kind == "cuda" else None)

    def wants_gbuffer(self, mode: str) -> bool:
        """The raster G-buffer only where the graph rasterises anyway (hybrid: the traced pixels
        are then the forward pass's); elsewhere primary hits come from rays on the device."""
        return mode == "hybrid"

    @property
    def gpu_ms(self) -> dict:
        """The dispatches' GPU times (ms) of the last frame the device has done and end_frame
        or drain read (no wait here)."""
        return self._flights.gpu_ms

    @property
    def rays_traced(self) -> int:
        """Rays traced by the frames that end_frame or drain read (no wait here)."""
        return self._flights.rays

    def frame_rays(self, since: int) -> int:
        """The rays of the last frame read: this one's after end_frame(0), else the one before's."""
        return self._flights.last_rays

    @_device_errors
    def end_frame(self, lag: int = 0) -> None:
        """The frame's work submitted; then the frames in flight read (their ray counts and
        timestamps) until at most lag of them are left: 0 waits for this frame, 1 for the one
        before it only, so that the device works on this frame while the host makes the next."""
        self._flights.end(self._encoding, self._submit_now, lag)

    @_device_errors
    def drain(self) -> None:
        """Until every frame in flight is done, and read."""
        self._submit()
        self._flights.retire(0)

    @property
    def adapter(self) -> str:
        return self.device.info.adapter_name

    def set_scene(self, scene) -> None:
        self.scene = DeviceScene(self.device, scene)

    def _pipeline(self, name: str, *args):
        if name not in self._pipelines:
            self._pipelines[name] = Pipeline(self.device, *args)
        return self._pipelines[name]

    def _buffer(self, name: str, count: int, stride: int):
        import slangpy as spy

        found = self._buffers.get(name)
        if found is None or found[1] != (count, stride):
            usage = spy.BufferUsage.unordered_access | spy.BufferUsage.shader_resource
            found = self._buffers[name] = (self.device.create_buffer(element_count=max(count, 1), struct_size=stride,
                                                                      usage=usage), (count, stride))
        return found[0]

    # -- memory shared with OpenGL (app/raster/interop.py) -----------------------------------
    def shared_buffer(self, nbytes: int) -> tuple:
        """A device buffer of at least nbytes that OpenGL can use too, and how to reach it:
        (buffer, ("fd", file descriptor, allocation size)) on Vulkan, where the memory is
        exported; (buffer, ("cuda", device address, nbytes)) on CUDA, where GL's own buffer is
        registered with CUDA and copied on the device. The caller keeps the buffer."""
        import slangpy as spy

        usage = spy.BufferUsage.unordered_access | spy.BufferUsage.shader_resource
        if self.name == "vulkan":
            # whole 64 KiB pages: the size GL imports is then the allocation's (NVIDIA wants it
            # exact), with room past nbytes (llvmpipe wants 48 bytes more than it maps)
            size = -(-(nbytes + 64) // 65536) * 65536
            buffer = self.device.create_buffer(size=size, usage=usage | spy.BufferUsage.shared)
            return buffer, ("fd", int(buffer.shared_handle.value), size)
        buffer = self.device.create_buffer(size=nbytes, usage=usage)
        return buffer, ("cuda", int(buffer.device_address), nbytes)

    def cuda_context(self) -> int:
        """The CUcontext of the CUDA device (its GL interop calls run in it)."""
        return int(self._native_handles()["CUcontext"])

    def cuda_ordinal(self) -> int:
        """The CUDA device's ordinal (OIDN's device ID)."""
        return int(self._native_handles()["CUdevice"])

    def _native_handles(self) -> dict:
        return {str(h.type).split(".")[-1]: h.value for h in self.device.native_handles}

    def wait(self) -> None:
        """Until the device has done the frame's work so far, and any upload (copy_from_numpy
        goes through the device's queue too)."""
        self._submit()
        self.device.wait()

    def _encoding(self):
        """The command encoder that the frame's dispatches are recorded in."""
        if self._encoder is None:
            self._encoder = self.device.create_command_encoder()
        return self._encoder

    def _submit(self) -> None:
        """Submit what the frame recorded so far (before the host reads or waits for it)."""
        if self._encoder is not None:
            encoder, self._encoder = self._encoder, None
            self._submitted = self.device.submit_command_buffer(encoder.finish())

    def _submit_now(self) -> int | None:
        self._submit()
        return self._submitted

    @_device_errors
    def export(self, image: Image, out) -> None:
        """image into the shared buffer out as GL's RGBA32F upload takes it (bottom row first,
        four channels): shaders/rt/export_gl.slang."""
        w, h = self.inputs.width, self.inputs.height
        self._compute("export_gl", w, h, {"g_image": image.buffer, "g_out": out, "g_width": w, "g_height": h,
                                          "g_channels": image.channels})

    # -- the frame ------------------------------------------------------------------------
    @_device_errors
    def begin_frame(self, inputs: FrameInputs) -> None:
        """Primary hits: the raster G-buffer unpacked on the device when the graph reads one
        back (wants_gbuffer), else rays from the eye through every pixel centre."""
        self._submit()  # the last frame's work goes first (host uploads below are not recorded)
        self.inputs = inputs
        cam, w, h = inputs.camera, inputs.width, inputs.height
        right, up, forward = (np.asarray(v, np.float32) for v in cam.basis())
        self.gbuffer = {name: self._buffer(f"gbuffer.{name}", w * h, 16)
                        for name in ("position", "normal", "true_normal", "albedo", "emissive", "view_dir")}
        if inputs.gbuffer is not None:
            self._unpack(inputs.gbuffer, cam, w, h, right, up, forward)
            return
        pipeline = self._pipeline("primary", "primary.slang", "primary_rays", ("primary_miss",), "primary_hit")

        def static(c):
            self.scene.bind_trace(c)
            self._bind_gbuffer(c["g_gbuffer"])
            c["g_width"], c["g_height"] = w, h

        def bind(c):
            c["g_eye"] = np.asarray(cam.eye, np.float32)
            c["g_right"], c["g_up"], c["g_forward"] = right, up, forward
            c["g_tan_half"] = float(np.tan(np.radians(cam.fov) / 2))
            c["g_jitter"] = np.asarray(inputs.jitter, np.float32)

        flight = self._flights.current
        flight.timers["primary"] = pipeline.dispatch(self._encoding(), w, h, bind, static, self._static_key(),
                                                     flight.slot)
        flight.primary += w * h
        self._submit()  # the device traces the primary rays while the host records the effects

    def _unpack(self, packed: dict, cam, w: int, h: int, right, up, forward) -> None:
        """packed: the two packed targets, as host arrays (GL's read-back) or as device buffers
        that GL wrote into (memory shared with GL: app/raster/interop.py)."""
        buffers = {}
        for name, words in (("geometry", 4), ("material", 4)):  # device buffers reused from frame to frame
            if not isinstance(packed[name], np.ndarray):
                buffers[name] = packed[name]
                continue
            buffers[name] = self._buffer(f"gbuffer.packed_{name}", w * h, 4 * words)
            # GL's read-back arrays are read-only views, which slangpy does not take: a writable copy
            staging = self._staging.get(name)
            if staging is None or staging.shape != packed[name].shape:
                staging = self._staging[name] = np.empty(packed[name].shape, np.uint32)
            np.copyto(staging, packed[name])
            buffers[name].copy_from_numpy(staging)
        self._compute("unpack", w, h, {
            "g_geometry": buffers["geometry"], "g_material": buffers["material"], "g_gbuffer": self.gbuffer,
            "g_width": w, "g_height": h, "g_eye": np.asarray(cam.eye, np.float32), "g_right": right, "g_up": up,
            "g_forward": forward, "g_tan_half": float(np.tan(np.radians(cam.fov) / 2)),
            "g_jitter": np.asarray(self.inputs.jitter, np.float32)})
        self._submit()  # the device unpacks while the host records the effects

    def _compute(self, name: str, w: int, h: int, variables: dict) -> None:
        """Dispatch the compute kernel `name` of shaders/rt/<name>.slang (entry point `name`,
        compiled once) over w x h threads, recorded with the frame's other work."""
        if name not in self._pipelines:
            self._pipelines[name] = ComputePipeline(self.device, name)
        self._pipelines[name].dispatch(self._encoding(), w, h, variables)

    def _static_key(self, *buffers) -> tuple:
        """What a pipeline's static fields depend on: the scene, the G-buffer's and the given
        buffers (new ones after a resize), the ray log, the image's size."""
        return (self.scene, *self.gbuffer.values(), *buffers, self._counter, self._recording, self.inputs.width,
                self.inputs.height)

    def _bind_gbuffer(self, cursor) -> None:
        for name, buf in self.gbuffer.items():
            cursor[name] = buf

    def _environment(self, cursor) -> None:
        """common.slang's Environment, from the same arguments as the Embree kernels'; a map's
        texels and sampling distribution (rt/environment.py) are uploaded once per map."""
        *values, texels = env_args(self.inputs.environment)
        for field, value in zip(("kind", "color", "horizon", "zenith", "ground"), values, strict=True):
            cursor[field] = value
        if self._env_texels is None or self._env_texels[0] is not texels:  # a new map: rare, so the wait is
            import slangpy as spy

            self.device.wait()  # for the frames that read the old one
            dist = env_distribution(self.inputs.environment)
            cdf = dist.cdf if dist is not None else np.array([0.0, 1.0], np.float32)
            cells = (dist.width, dist.height) if dist is not None else (0, 0)
            buf, cdf_buf = (self.device.create_buffer(element_count=a.size, struct_size=4,
                                                      usage=spy.BufferUsage.shader_resource, data=a.reshape(-1))
                            for a in (texels, cdf))
            self._env_texels = (texels, buf, cdf_buf, cells)
        _, buf, cdf_buf, cells = self._env_texels
        cursor["texels"], cursor["cdf"] = buf, cdf_buf
        cursor["width"], cursor["height"] = int(texels.shape[1]), int(texels.shape[0])
        cursor["cells_u"], cursor["cells_v"] = cells

    @_device_errors
    def trace(self, effect: str, channels: tuple[str, ...] = ("radiance",)) -> dict:
        if effect not in EFFECTS:
            raise UserError(f"{effect} is not on the {self.name} backend yet (it traces {', '.join(EFFECTS)}); "
                            f"use --set tracer=embree")
        return self._run(effect, channels)

    def _options(self, effect: str, opts) -> dict:
        """The effect shader's option uniforms: its record's parameters as `g_<name>` (flags 0 or 1)."""
        return {f"g_{k}": int(v) if isinstance(v, bool) else v for k, v in PASSES[effect].parameters(opts).items()}

    def _run(self, effect: str, channels) -> dict:
        """One effect's pipeline over the image: radiance (3 floats a pixel) and its own image."""
        from rt.keys import key_base

        inputs = self.inputs
        w, h = inputs.width, inputs.height
        file, raygen = shader_file(effect), f"{effect}_rays"
        stream, aux_channels = STREAM[effect], AUX_CHANNELS[effect]
        aux_name = AUX_CHANNEL.get(effect, "unused")
        out = self._buffer("radiance", w * h * 3, 4)
        aux = self._buffer(aux_name, w * h * aux_channels, 4)
        splits = SPECULAR in PASSES[effect].writes  # its shader has g_spec (rt_specular)
        spec = self._buffer(SPECULAR, w * h * 3 if SPECULAR in channels else 1, 4)  # the image only when asked
        pipeline = self._pipeline(effect, file, raygen, MISSES, "closest")
        values = self._options(effect, inputs.options)

        def static(c):  # what stays the same from frame to frame: written when it changes
            self.scene.bind_trace(c)
            self._bind_gbuffer(c["g_gbuffer"])
            self._bind_log(c)
            if PASSES[effect].lights:
                self.scene.bind_lights(c["g_lights"])
                c["g_far"] = float(self.scene.arrays.far)
            c["g_out"], c["g_aux"], c["g_rays_traced"] = out, aux, self._counter
            if splits:
                c["g_spec"] = spec
            c["g_width"] = w

        def bind(c):
            if PASSES[effect].lights:
                c["g_ggx"] = int(self.scene.arrays.scene.uses_ggx(inputs.options.get("brdf")))
            self._environment(c["g_env"])
            c["g_base"] = np.array(_key_words(key_base(inputs.seed, inputs.index, stream)), np.uint32)
            c["g_write_aux"] = int(aux_name in channels)
            if splits:
                c["g_write_spec"] = int(SPECULAR in channels)
            for name, value in values.items():
                c[name] = value

        flight = self._flights.current
        flight.counted = True  # the counter is read once the frame is done (end_frame)
        flight.timers[effect] = pipeline.dispatch(self._encoding(), w, h, bind, static,
                                                  self._static_key(out, aux, spec), flight.slot)
        images = {"radiance": Image(out, w * h, 3), aux_name: Image(aux, w * h, aux_channels),
                  SPECULAR: Image(spec, w * h, 3)}
        return {c: images[c] for c in channels}

    def _bind_log(self, cursor) -> None:
        """The ray log of trace.slang: the recording's while a frame is recorded, else an unused one."""
        log, capacity = self._recording if self._recording is not None else (self._buffer("log.none", 2, 16), 0)
        cursor["g_ray_log"], cursor["g_log_count"], cursor["g_log_capacity"] = log, self._log_count, capacity

    def record(self, capacity: int) -> None:
        """Log every ray the effects trace until replay() (bench --perf), up to capacity rays."""
        self._submit()
        self._recording = (self._buffer("log", 2 * max(capacity, 1), 16), int(capacity))
        self._log_count.copy_from_numpy(np.zeros(1, np.uint32))

    @_device_errors
    def replay(self) -> tuple[int, float, bool]:
        """Trace the recorded rays again alone (shaders/rt/replay.slang); ends the recording.
        Returns (rays, GPU ms, whether every ray fitted in the log)."""
        self._submit()
        log, capacity = self._recording
        self._recording = None
        logged = int(self._log_count.to_numpy().view(np.uint32)[0])
        count = min(logged, capacity)
        row = 4096
        pipeline = self._pipeline("replay", "replay.slang", "replay_rays", MISSES, "closest")
        sink = self._buffer("log.sink", 1, 4)

        def bind(c):
            self.scene.bind_trace(c)
            c["g_ray_log"], c["g_log_count"], c["g_log_capacity"] = log, self._log_count, 0
            c["g_count"], c["g_row"], c["g_sink"] = count, row, sink

        timer = pipeline.dispatch(self._encoding(), row, max(1, -(-count // row)), bind)
        self.wait()
        ms = timer()
        return count, ms, logged <= capacity

    @_device_errors
    def svgf(self, radiance: Image, run, specular: Image | None = None) -> Image:
        """SVGF on the device (rt/slang/svgf.py), recorded with the frame's other work."""
        if self._svgf is None:
            self._svgf = DeviceSvgf(self)
        return self._svgf.run(radiance, run, specular)

    def on_device(self, denoiser: str) -> bool:
        if denoiser != "oidn":
            return denoiser in self.denoisers
        if self._oidn is None and self.oidn_note is None:
            from rt.slang.oidn import DeviceOidn
            from rt.slang.oidn_library import OidnError

            try:
                self._oidn = DeviceOidn(self)
            except OidnError as e:
                self.oidn_note = str(e)
        return self._oidn is not None

    @_device_errors
    def present(self, radiance, weight: float, exposure: float, display=None, oidn=None) -> tuple:
        """The end of the frame on the device: the running mean of radiance (weight: 1 / (frames
        so far + 1), 1 restarts it, 0 keeps it) and its tone-mapped 8-bit RGBA (rows bottom-up,
        as GL stores a texture), into display where given (a buffer shared with GL); with oidn
        (rt/oidn.py's OidnFrame, where on_device("oidn")), the mean denoised by OIDN on the GPU
        (rt/slang/oidn.py) and shown instead. Returns the image shown and the 8-bit one as
        device images: only the 8-bit one need leave the device (to_host)."""
        inputs = self.inputs
        w, h = inputs.width, inputs.height
        mean = self._buffer("accumulated", w * h, 16)
        display = self._buffer("display", w * h, 4) if display is None else display
        self._compute("present", w, h, {"g_radiance": radiance.buffer, "g_accumulated": mean, "g_display": display,
                                        "g_width": w, "g_height": h, "g_weight": float(weight),
                                        "g_exposure": float(exposure)})
        shown = Image(mean, w * h, 4)
        if oidn is not None and self._oidn is not None:
            from rt.slang.oidn_library import OidnError

            try:
                shown, display = self._oidn.run(shown, oidn, exposure, display)
            except OidnError as e:  # this frame shown as it is; the next ones denoised on the CPU (oidn_note)
                self.oidn_note = f"OIDN's GPU device failed: {e}"
                self._oidn = None
        return shown, Rgba8(display, w, h)

    @_device_errors
    def gbuffer_view(self, channel: str) -> np.ndarray:
        """A G-buffer channel of the device's primary hits, read back (a debugging view: one
        transfer a frame is fine); uncovered pixels 0, as on Embree."""
        self._submit()
        inputs = self.inputs
        n = inputs.width * inputs.height
        read = {name: buf.to_numpy().view(np.float32)[: 4 * n].reshape(n, 4) for name, buf in self.gbuffer.items()}
        covered = read["position"][:, 3] > 0
        values = {"albedo": read["albedo"][:, :3], "normal": read["normal"][:, :3], "position": read["position"][:, :3],
                  "roughness": read["normal"][:, 3:4], "metallic": read["true_normal"][:, 3:4],
                  "emissive": read["emissive"][:, :3],
                  "depth": read["albedo"][:, 3:4]}
        if channel == "motion":
            values["motion"] = inputs.motion(read["position"][:, :3])
        v = np.broadcast_to(values[channel], (n, 3)) if values[channel].shape[1] == 1 else values[channel]
        return np.where(covered[:, None], v, 0.0).astype(np.float32)

    @_device_errors
    def to_host(self, image) -> np.ndarray:
        self._submit()
        return image if isinstance(image, np.ndarray) else image.to_numpy()

    def close(self) -> None:
        self._submit()
        if self._oidn is not None:
            self.device.wait()
            self._oidn.close()
            self._oidn = None
        self.scene = None
        self._buffers.clear()
