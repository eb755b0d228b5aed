"""The frame loop shared by the headless runner, the benchmark and the viewer:
scene -> G-buffer -> pass -> accumulation -> display. Dirty frames reset accumulation."""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from app.camera import Camera, subpixel_jitter
from app.frame import Frame
from app.graph import Resolved, active, denoises, finish_on_tracer, gbuffer_source
from app.options import Options
from app.passes import check_pass, create_passes
from app.profiler import Profiler
from app.raster.channel_view import CHANNEL_VIEWS
from app.raster.gpu_scene import GpuScene
from app.raster.upload import Uploads, read_rgba
from core.errors import DeviceError, UserError
from rt.oidn import oidn_frame
from scenes.loaders.envmap import parse_env
from scenes.model import Environment

JITTERED_STILL_FRAMES = 64  # a still forward view stops re-rendering after this many jittered frames


@dataclass
class Job:
    """One frame between prepare() and finish(); the ray-traced part runs in compute()."""

    frame: Frame
    state: tuple
    pass_name: str
    gl_before: list  # passes run in prepare() (GL thread)
    traced: list  # passes run in compute() on the backend (any thread)
    gl_after: list  # passes run in finish() (GL thread), the tail included
    wanted: dict  # pass -> the channels the rest of the graph reads from it
    present: bool = False  # the backend accumulates and tone-maps on its device (the GL tail does not run)
    oidn: object = None  # rt/oidn.py's OidnFrame where the backend denoises the image shown on its GPU
    presented: tuple | None = None  # (running mean on the device, 8-bit image or its Link, accumulation count)
    readback: tuple = ()  # channels the backend makes that the GL passes after it read
    links: dict | None = None  # shared memory (app/raster/interop.py) for readback and "display", made here
    exported: tuple = ()  # the readback channels the backend wrote into their links (the rest are copied)
    in_flight: bool = False  # the device may still work on this frame when GL shows the one before (finish)
    lag: int = 0  # 1: GL shows the frame before this one, which the device has done (compute decides)

    @property
    def cpu(self) -> bool:
        """Whether compute() has work (the viewer runs it off the GL thread)."""
        return bool(self.traced)


def prune(passes: dict, names: list[str]) -> list[str]:
    """The passes of a graph that something reads from (the display being what is shown):
    walking back from the end, a pass none of whose writes a later pass reads is dropped."""
    needed, kept = {"display"}, []
    for name in reversed(names):
        p = passes[name]
        if needed & set(p.writes):
            kept.append(name)
            needed = (needed - set(p.writes)) | set(p.reads)
    return kept[::-1]


def wiring(passes: dict, names: list[str], every_output: bool) -> dict:
    """For each pass of a frame's graph, the channels of its writes that a later pass reads
    (all of them if every_output): walking back from the display."""
    needed, wanted = set(), {}
    for name in reversed(names):
        p = passes[name]
        wanted[name] = frozenset(p.writes if every_output else needed & set(p.writes))
        needed = (needed - set(p.writes)) | set(p.reads)
    return wanted


class Renderer:
    def __init__(self, ctx, scene, options: Options | None = None, profiler: Profiler | None = None,
                 prefetch: bool = False):
        """prefetch: a ray-traced pass is wanted soon (shot, bench, viewer): each scene's arrays
        for the ray-tracing backend are made on a thread while GL uploads it (rt/mesh.py)."""
        self.ctx = ctx
        self.prefetch = prefetch
        self.options = options or Options()
        self.profiler = profiler or Profiler()
        self.passes = create_passes(ctx)
        self.accumulation = self.passes["accumulation"]
        self.uploads = Uploads(ctx)
        self.gpu = None
        self.rt = None  # the ray-tracing backend (rt.backend.Backend), made on first use
        self.interop = None  # memory shared with self.rt's device (app/raster/interop.py), or None: copies
        self._interop_checked = None  # the backend whose sharing was tried
        self.notices: list[str] = []  # lines said once (the CLI prints them, the viewer shows them)
        self.scene = None
        self.set_scene(scene)
        self._state = None
        self.prev_camera = None
        self.frame: Frame | None = None
        self.seed = 0
        # frames since reset() or a change but the camera's: their draws and jitter
        self.frames_made = self.first_frame = 0
        # the viewer sets this: a deterministic (raster) frame whose inputs did not change is
        # shown again instead of re-rendered, which keeps the UI responsive on software GL
        self.reuse_static_frames = False
        # frames in flight (option frames_in_flight): the slot of the next in-flight frame's
        # display image, the link GL took the last display from, whether the last frame's is unshown
        self._flight_slot, self._shown, self._unshown = 0, None, False
        self._fences = None  # GL fences after the uploads of shown images (app/raster/gl_fence.py)
        # ray-traced passes make their images besides radiance (rt_direct, rt_ao, ...) only when
        # the graph reads them, or when this is set (tests, scripts that read them)
        self.pass_outputs = False
        self._software_gl = None  # whether this GL is a CPU rasteriser (gbuffer_source), once asked

    def set_scene(self, scene) -> None:
        """scene for every pass and backend (with its textures made smaller where option
        textures.max_size asks: scenes/texture_limit.py)."""
        from scenes.texture_limit import limited

        self.source_scene = scene
        self._texture_side = int(self.options.get("textures.max_size"))
        scene = limited(scene, self._texture_side)
        if self.prefetch:
            from rt.mesh import prefetch

            prefetch(scene)
        if self.gpu is not None:
            self.gpu.release()
        if self.rt is not None:
            self._drop_interop()
            self.rt.close()
            self.rt = None
        self.scene = scene
        self.gpu = GpuScene(self.ctx, scene)
        self._state = None
        for p in self.passes.values():
            p.set_scene(scene)
            p.reset()

    def software_gl(self) -> bool:
        """Whether this GL is a CPU rasteriser (asked once)."""
        from app.gl_context import software_gl

        if self._software_gl is None:
            self._software_gl = software_gl(self.ctx)
        return self._software_gl

    def finishes_on_tracer(self, backend=None) -> bool:
        """Option finish resolved for this renderer's ray-traced frames (app/graph.py finish_on_tracer)."""
        from rt.backends import resolve

        name = backend.name if backend is not None else resolve(self.options.get("tracer"))
        return finish_on_tracer(self.options, name, self.software_gl())

    def gbuffer_source(self, pass_name: str) -> str:
        """Option gbuffer resolved for this renderer's frames of pass_name (app/graph.py gbuffer_source)."""
        from rt.backends import resolve

        return gbuffer_source(self.options, resolve(self.options.get("tracer")), self.software_gl(), pass_name)

    def ray_tracing(self):
        """The scene's ray-tracing backend (option `tracer`), built on first use and again when
        the option names another (the BVH build takes time). If the one asked for cannot be
        made, the option goes back to the backend in use, which keeps running, and the error
        is raised (the viewer shows it; the CLI prints it)."""
        from rt.backends import create, resolve

        asked = self.options.get("tracer")
        name = resolve(asked)
        if self.rt is None or self.rt.name != name:
            try:
                backend = create(name)
                with self.profiler.cpu("bvh_build"):
                    backend.set_scene(self.scene)
            except UserError:
                if self.rt is not None and asked != "auto":
                    self.options.set("tracer", self.rt.name)
                raise
            if self.rt is not None:
                self._drop_interop()
                self.rt.close()
            self.rt = backend
        return self.rt

    def sharing(self, backend):
        """The memory this GL context shares with backend's device (app/raster/interop.py), or
        None where images go through host memory: option interop=copy, a CPU backend, or a
        driver without sharing (said once in notices)."""
        from app.raster.interop import Interop, Unavailable

        if backend is None or self.options.get("interop") == "copy" or not hasattr(backend, "shared_buffer"):
            return None
        if self._interop_checked is not backend:
            self._drop_interop()
            self._interop_checked = backend
            try:
                self.interop = Interop.create(self.ctx, backend)
            except Unavailable as e:
                note = f"{backend.name}: images go through host memory ({e})"
                if note not in self.notices:
                    self.notices.append(note)
            except DeviceError:
                self.options.set("tracer", "embree")
                raise
        return self.interop

    def _links(self, frame: Frame, job: Job) -> dict | None:
        """The shared memory of this frame's images that GL takes from the device; None (and
        copies from now on, said once) if the driver refuses it."""
        from app.raster.interop import Unavailable

        n = frame.width * frame.height
        try:
            links = {name: frame.interop.link(f"rt.{name}", 16 * n) for name in job.readback}
            if job.present:  # frames in flight alternate between two
                links["display"] = frame.interop.link(f"display.{self._flight_slot if job.in_flight else 0}", 4 * n)
            return links
        except Unavailable as e:
            self._sharing_failed(frame.backend, e)
            frame.interop = None
            return None

    def _presents(self, backend, pass_name: str, names: list[str]) -> bool:
        """Whether the backend's own image ends this graph: after its traced passes only the
        accumulation and the display, which it does on its device (Backend.present) where option
        finish puts them there (app/graph.py finish_on_tracer)."""
        traced = [i for i, n in enumerate(names) if self.passes[n].device == "rt"]
        return (backend is not None and hasattr(backend, "present") and pass_name not in CHANNEL_VIEWS
                and bool(traced) and names[traced[-1] + 1:] == ["accumulation", "display"]
                and self.finishes_on_tracer(backend))

    def _device_oidn(self, backend) -> bool:
        """Whether OIDN runs on the backend's GPU this frame (option oidn.device); where a GPU
        backend has no OIDN device, on the CPU, said once in notices."""
        if not self.options.get("oidn.device"):
            return False
        if backend.on_device("oidn"):
            return True
        note = getattr(backend, "oidn_note", None)
        if note and f"oidn: on the CPU ({note})" not in self.notices:
            self.notices.append(f"oidn: on the CPU ({note})")
        return False

    def _sharing_failed(self, backend, error) -> None:
        """Sharing that worked stopped working (a driver's refusal mid-run): copies from now on
        for this backend, said once."""
        self.notices.append(f"{backend.name}: images go through host memory ({error})")
        self._drop_interop()
        self._interop_checked = backend  # not tried again for this backend

    def _drop_interop(self) -> None:
        if self.interop is not None:
            if self.rt is not None:
                try:
                    self.rt.drain()  # no frame in flight writes the links released here
                except DeviceError:
                    pass  # a lost device writes nothing more
            self.interop.release()
        self.interop, self._interop_checked = None, None
        self._shown, self._unshown = None, False

    def environment(self) -> Environment:
        """The radiance of missed rays: the scene's or option env's, scaled by env.intensity."""
        env = self.options.get("env")
        found = self.scene.environment if env == "scene" else parse_env(env)
        scale, turn = float(self.options.get("env.intensity")), float(self.options.get("env.rotation"))
        if scale == 1.0 and turn == 0.0:
            return found
        return dataclasses.replace(found, color=tuple(float(c) * scale for c in found.color) if found.kind == "constant"
                                   else found.color, strength=found.strength * scale, rotation=found.rotation + turn)

    @property
    def frame_count(self) -> int:
        return self.accumulation.count

    def reset(self, first_frame: int = 0) -> None:
        """Start afresh: accumulation, the frame numbering (from first_frame: a batch of a longer
        run, numbered as that run numbers it) and every pass's history (SVGF's)."""
        self._state = None
        self.frames_made = self.first_frame = first_frame
        for p in self.passes.values():
            p.reset()

    def jittering(self, pass_name: str) -> bool:
        """Whether this mode's frames sample jittered points of their pixels: where frames are
        combined over time, by accumulation or by SVGF's temporal history (which otherwise sees
        every pixel through the same point, and aliases edges that accumulation blends); not the
        G-buffer's data views, whose values are not light."""
        opts = self.options
        temporal = bool(opts.get("accumulate")) or (opts.get("denoise") == "svgf" and denoises(pass_name))
        return bool(opts.get("jitter")) and temporal and pass_name not in CHANNEL_VIEWS

    def deterministic(self, pass_name: str) -> bool:
        """Whether another frame of unchanged inputs would look the same: the data views, and the
        forward mode, which with jitter antialiases over its first JITTERED_STILL_FRAMES frames."""
        if pass_name in CHANNEL_VIEWS:
            return True
        return pass_name == "forward" and (not self.jittering(pass_name)
                                           or self.accumulation.count >= JITTERED_STILL_FRAMES)

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
        """The mode's GL passes up to its first ray-traced one. None: the last frame still holds."""
        check_pass(pass_name)
        if int(self.options.get("textures.max_size")) != self._texture_side:  # the GPU scene and backend again
            self.set_scene(self.source_scene)
        state = self.state_of(camera, width, height, pass_name)
        max_frames = int(self.options.get("max_frames"))
        converged = bool(self.options.get("accumulate")) and max_frames and self.accumulation.count >= max_frames
        if (self.reuse_static_frames and state == self._state and self.frame is not None
                and (self.deterministic(pass_name) or converged)):
            self.settle()  # the last frame's own image, where frames in flight showed the one before
            return None  # nothing would change: show the last frame
        moved = False
        if state != self._state:
            camera_only = self._state is not None and state[:1] + state[2:] == self._state[:1] + self._state[2:]
            # with reproject, a moved camera carries the mean on (app/raster/reproject.py): only
            # the count of still frames restarts
            moved = bool(self.options.get("reproject")) and camera_only
            if not camera_only:  # another image: numbered afresh, as a new renderer's would be
                self.frames_made = self.first_frame
            self.accumulation.reset()
            self._state = state
        self.profiler.begin_frame()
        names = active(pass_name, Resolved(self.options, gbuffer=self.gbuffer_source(pass_name)))
        backend = self.ray_tracing() if any(self.passes[n].device == "rt" for n in names) else None
        if backend is not None and "svgf" in names and self.options.get("svgf.device") and backend.on_device("svgf"):
            # SVGF on the backend's device (rt/svgf.py): the frame stays there
            names = prune(self.passes, ["svgf_device" if n == "svgf" else n for n in names])
        if backend is not None and not backend.wants_gbuffer(pass_name):  # it traces its own primary hits
            names = prune(self.passes, [n for n in names if n != "gbuffer_pack"])
        device_oidn = False
        if backend is not None and "oidn" in names and self._device_oidn(backend):
            # OIDN on the backend's GPU, at the end of the frame there (Backend.present), where
            # that ends the frame (with reproject on, the GL tail runs, OIDN in it)
            without = prune(self.passes, [n for n in names if n != "oidn"])
            if self._presents(backend, pass_name, without):
                names, device_oidn = without, True
        traced = [n for n in names if self.passes[n].device == "rt"]
        first = names.index(traced[0]) if traced else len(names)
        last = names.index(traced[-1]) + 1 if traced else len(names)
        # frames number their random draws from the last change of anything but the camera, on
        # through restarts of the mean, so that each frame's noise is new (a moving camera's, a
        # denoiser's input) and a still image is the one a fresh renderer makes
        index = self.frames_made
        self.frames_made += 1
        frame = Frame(self.ctx, self.scene, self.gpu, camera, self.prev_camera or camera, width, height, self.options,
                      self.profiler, self.environment(), index, self.seed, pass_name, backend)
        frame.moved = moved
        frame.interop = self.sharing(backend)
        if self.jittering(pass_name):
            frame.jitter = subpixel_jitter(frame.index)
        job = Job(frame, state, pass_name, names[:first], names[first:last], names[last:],
                  wiring(self.passes, names, self.pass_outputs))
        # a device backend's own image ends the frame there: only 8 bits a channel come back
        if self._presents(backend, pass_name, names):
            job.present, job.gl_after = True, []
            job.oidn = oidn_frame(pass_name, self.options, self.scene) if device_oidn else None
        made = {c for n in job.traced for c in self.passes[n].writes}
        read = {c for n in job.gl_after for c in self.passes[n].reads}
        job.readback = tuple(sorted(made & read))
        # the device may work on this frame while GL shows the one before: where it presents the
        # image and nothing else of it goes to GL
        job.in_flight = (job.present and frame.interop is not None and not job.readback
                         and int(self.options.get("frames_in_flight")) > 1)
        if job.in_flight:
            self._flight_slot ^= 1
            if self._fences is not None:  # GL has read the image the device is to write next
                self._fences.wait(0)
        if frame.interop is not None:  # GL objects are made on this (the GL) thread
            job.links = self._links(frame, job)
        job.in_flight = job.in_flight and job.links is not None
        self._run(job, job.gl_before)
        return job

    def compute(self, job: Job) -> None:
        """The ray-traced passes of a frame, on the backend; safe to run on a worker thread."""
        if not job.traced:
            return
        backend = job.frame.backend
        rays0 = backend.rays_traced
        shown = self._shown
        job.lag = int(job.in_flight and shown is not None and shown.nbytes == job.links["display"].nbytes
                      and shown is not job.links["display"])
        try:
            self._run(job, job.traced)
            if job.present:
                with self.profiler.cpu("present"):
                    job.presented = self._present(job)
            if job.links:  # the images GL reads, written into the memory it shares
                with self.profiler.cpu("share"):
                    channels = job.frame.channels
                    job.exported = tuple(n for n in job.readback if hasattr(channels.get(n), "buffer"))
                    for name in job.exported:  # device images (a G-buffer view is a host array)
                        backend.export(channels[name], job.links[name].device)
                    if not job.lag:
                        job.frame.interop.device_done()
            # in flight: the host goes on while the device does this frame (finish shows the one
            # before); the frames' ray counts and timestamps are read as they are done
            backend.end_frame(job.lag)
        except DeviceError:
            self.options.set("tracer", "embree")  # the next frame (ray_tracing) builds Embree's
            raise
        with self.profiler.cpu("counters"):  # the frame's ray count and GPU timestamps, read once it is done
            self.profiler.count("rays", backend.frame_rays(rays0))
            gpu_ms = backend.gpu_ms
        for name, ms in gpu_ms.items():  # a GPU backend's own timestamps
            self.profiler.record(f"{name}_gpu", ms, "gpu")

    def _shared_to_gl(self, job: Job) -> dict:
        """The links the device wrote this frame, handed to GL, and the textures GL passes read
        filled from them; {} where there are none or the hand-over failed (the images are then
        read back as without sharing, and sharing stays off, said once)."""
        from app.raster.interop import Unavailable

        frame = job.frame
        if not job.links:
            return {}
        links = {n: job.links[n] for n in (*job.exported, "display") if n in job.links}
        try:
            with self.profiler.cpu("share"):
                frame.interop.to_gl(list(links.values()))
                for name in job.exported:
                    frame.channels[name] = self.uploads.from_buffer(name, links[name].gl, frame.width, frame.height)
        except Unavailable as e:
            self._sharing_failed(frame.backend, e)
            job.exported = ()
            return {}
        return links

    def _present(self, job: Job) -> tuple:
        """Accumulation and display on the backend's device, as AccumulationPass and DisplayPass
        do them in GL: the running mean (restarted, extended, or kept once max_frames is
        reached), then exposure, ACES and sRGB."""
        frame, count = job.frame, self.accumulation.count
        max_frames = int(self.options.get("max_frames"))
        if not self.options.get("accumulate"):
            weight, count = 1.0, 0
        elif max_frames and count >= max_frames:
            weight = 0.0
        else:
            weight, count = 1.0 / (count + 1), count + 1
        shared = (job.links or {}).get("display")
        mean, display = frame.backend.present(frame.channels["radiance"], weight, float(self.options.get("exposure")),
                                              shared.device if shared is not None else None, oidn=job.oidn)
        if shared is not None:  # GL takes the image from the memory it shares (finish)
            return mean, display, count
        with self.profiler.cpu("device_readback"):  # the one transfer of the frame: 8 bits a channel
            image = frame.backend.to_host(display)
        return mean, image, count

    def finish(self, job: Job) -> Frame:
        """Uploads of what the backend made for GL passes, then the rest: accumulation, display."""
        frame = job.frame
        if job.lag:  # the frame before's image, which the device has done, goes up before this one's
            with self.profiler.cpu("upload"):  # is handed to GL (on CUDA, GL work after that waits for it)
                frame.channels["display"] = self._show(self._shown, frame)
        shared = self._shared_to_gl(job)
        if job.presented is not None:
            mean, image, self.accumulation.count = job.presented
            frame.channels["accumulated"] = mean
            with self.profiler.cpu("upload"):
                if "display" in shared:
                    if not job.lag:
                        frame.channels["display"] = self._show(shared["display"], frame)
                else:  # read back here where sharing failed this frame
                    image = image if isinstance(image, np.ndarray) else frame.backend.to_host(image)
                    frame.channels["display"] = self.uploads.upload_rgba8("display", image)
            self._unshown = bool(job.lag) and "display" in shared
            self._shown = shared.get("display") if job.in_flight else None
        if not job.in_flight:  # this frame's image is shown: nothing left in flight to show
            self._shown, self._unshown = None, False
        if job.traced:
            for name in (set(job.readback) - set(job.exported)) & set(frame.channels):
                with self.profiler.cpu("device_readback"):  # nothing to move for Embree's numpy images
                    try:
                        image = frame.backend.to_host(frame.channels[name])
                    except DeviceError:
                        self.options.set("tracer", "embree")
                        raise
                frame.channels[name] = self._upload(frame, name, image)
        self._run(job, job.gl_after)
        self.profiler.end_frame()
        self.prev_camera = frame.camera.copy()
        self.frame = frame
        return frame

    def _run(self, job: Job, names: list[str]) -> None:
        frame = job.frame
        for name in names:
            frame.wanted = job.wanted[name]
            self.passes[name].execute(frame)

    def _upload(self, frame: Frame, name: str, image: np.ndarray):
        with self.profiler.cpu("upload"):
            return self.uploads.upload(name, image, frame.width, frame.height)

    def _show(self, link, frame: Frame):
        """The display texture from a link the device has written (and handed to GL); with
        frames in flight, a fence after it, which the next in-flight frame waits for before the
        device writes that link again (prepare)."""
        tex = self.uploads.rgba8_from_buffer("display", link.gl, frame.width, frame.height)
        if frame.backend is not None and int(self.options.get("frames_in_flight")) > 1:
            if self._fences is None:
                from app.raster.gl_fence import Fences

                self._fences = Fences(self.ctx)
            self._fences.insert()
        return tex

    def settle(self) -> None:
        """The last frame's own image shown (frames in flight show the one before): waits for
        the device."""
        if self._unshown and self.frame is not None and self._shown is not None:
            self.frame.backend.drain()
            self.frame.channels["display"] = self._show(self._shown, self.frame)
            self._unshown = False

    # -- read back (row 0 = top of the image) ---------------------------------------------
    def read_display(self) -> np.ndarray:
        self.settle()
        tex = self.frame.channels["display"]
        w, h = tex.size
        data = np.frombuffer(tex.read(), np.uint8).reshape(h, w, 4)
        return np.ascontiguousarray(data[::-1, :, :3])

    def read_linear(self) -> np.ndarray:
        acc = self.frame.channels["accumulated"]
        if self.frame.backend is not None and not hasattr(acc, "read"):  # the running mean on the device
            h, w = self.frame.height, self.frame.width
            return np.ascontiguousarray(self.frame.backend.to_host(acc).reshape(h, w, -1)[..., :3])
        return np.ascontiguousarray(read_rgba(acc)[..., :3])

    def release(self) -> None:
        for p in self.passes.values():
            p.release()
        self.uploads.release()
        if self._fences is not None:
            self._fences.release()
        self.gpu.release()
        if self.rt is not None:
            self._drop_interop()
            self.rt.close()
