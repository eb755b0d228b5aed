"""What a ray-tracing backend offers the passes: one interface, whatever the device.

A backend builds the scene once (`set_scene`), takes a frame's inputs (`begin_frame`: the
camera, the options, and the raster G-buffer when the pass graph feeds one, else it traces
primary rays itself), traces one effect at a time into named images (`trace`), and hands an
image to the host only when asked (`to_host`). Images stay on the backend's device between
effects: a GPU backend keeps the whole frame there, Embree's images are numpy arrays.

Images are (width x height, channels) float32 rows, row 0 the top-left pixel."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rt.effects import AUX_CHANNEL, EFFECTS  # noqa: F401  (the backends' names for them)


@dataclass
class FrameInputs:
    camera: object  # app.camera.Camera (eye, basis(), fov, view and projection matrices)
    prev_camera: object  # the last frame's camera (motion vectors)
    width: int
    height: int
    environment: object  # scenes.model.Environment in effect
    options: object  # core.options.Options
    seed: int = 0
    index: int = 0  # frames since the last reset: seeds this frame's random numbers
    gbuffer: dict | None = None  # the raster G-buffer packed for the CPU (app/raster/gbuffer_pack.py), or None
    jitter: tuple = (0.0, 0.0)  # this frame's subpixel offset of the primary samples (pixels: right, down)

    def motion(self, positions: np.ndarray) -> np.ndarray:
        """(N, 3) motion vectors, in pixels, of the points at `positions`: where the last frame's
        camera saw them to where this frame's sees them, both without the subpixel jitter (third
        column 0), as the raster G-buffer's motion channel."""
        now, before = (self._pixel_of(positions, cam) for cam in (self.camera, self.prev_camera))
        return np.c_[now - before, np.zeros(len(positions))]

    def view_projection(self, camera) -> np.ndarray:
        """A camera's view-projection at this frame's aspect, without the subpixel jitter."""
        return camera.projection_matrix(self.width / max(self.height, 1)) @ camera.view_matrix()

    def _pixel_of(self, positions: np.ndarray, camera) -> np.ndarray:
        """Window coordinates (pixels, y up, as GL's) of points seen by a camera."""
        m = self.view_projection(camera)
        clip = np.c_[positions, np.ones(len(positions))] @ m.T
        ndc = clip[:, :2] / np.maximum(np.abs(clip[:, 3:4]), 1e-9) * np.sign(clip[:, 3:4])
        return (ndc * 0.5 + 0.5) * [self.width, self.height]


class Backend:
    """A ray tracer behind the passes. Subclasses: rt/embree/backend.py (more in rt/backends.py)."""

    name = ""
    rays_traced = 0  # rays traced since creation (the profiler's ray count reads the difference)
    denoisers: tuple[str, ...] = ()  # the denoisers it may run on its own device (svgf: rt/svgf.py; oidn: rt/oidn.py)

    def on_device(self, denoiser: str) -> bool:
        """Whether it runs this denoiser (option denoise) on its own device, here: svgf through
        svgf(), oidn through present()."""
        return denoiser in self.denoisers

    def wants_gbuffer(self, mode: str) -> bool:
        """Whether begin_frame takes the raster G-buffer in this pass mode (when the graph
        rasterises one); else the backend traces its own primary hits."""
        return True

    def set_scene(self, scene) -> None:
        """Upload the scene and build its acceleration structure (once per scene)."""
        raise NotImplementedError

    def begin_frame(self, inputs: FrameInputs) -> None:
        """Primary visibility for this frame: from inputs.gbuffer, or primary rays if None."""
        raise NotImplementedError

    def trace(self, effect: str, channels: tuple[str, ...] = ("radiance",)) -> dict:
        """Trace one effect (EFFECTS) of the current frame with its options; returns the asked
        channels ("radiance" and/or the effect's AUX_CHANNEL) as device images."""
        raise NotImplementedError

    gpu_ms: dict = {}  # a device backend's GPU time per dispatch of the last frame read (ms), by name

    def frame_rays(self, since: int) -> int:
        """The rays of the frame that the profiler counts, given rays_traced before it: this
        frame's here; a backend with frames in flight gives the last one it has read."""
        return self.rays_traced - since

    def end_frame(self, lag: int = 0) -> None:
        """The frame's work is all recorded: a device backend submits it, then waits until at
        most lag frames are still in flight (0: this one is done), reading their ray counts and
        timestamps (rays_traced, gpu_ms). Backends that work on the host have nothing to do."""

    def drain(self) -> None:
        """Until every frame in flight is done and read (end_frame with lag 0 of the last one)."""

    def svgf(self, radiance, run, specular=None) -> object:
        """radiance (this frame's image) filtered by SVGF on the device (where "svgf" is in
        denoisers) as run (rt/svgf.py's SvgfFrame: options, iterations, what the radiance holds
        of the first hit, whether the last frame's history may be reprojected)."""
        raise NotImplementedError

    def gbuffer_view(self, channel: str) -> object:
        """A G-buffer channel (albedo, normal, position, depth, roughness, emissive, motion) of
        the current frame's primary hits, as a 3-channel device image."""
        raise NotImplementedError

    def to_host(self, image) -> object:
        """A device image as a numpy (width x height, channels) float32 array."""
        raise NotImplementedError

    def close(self) -> None:
        """Release the scene and the device's resources."""
