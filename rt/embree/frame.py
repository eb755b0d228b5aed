"""What a ray-traced pass receives: the CPU G-buffer, the tracer, the scene's shading data."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from rt.embree.gbuffer import CpuGBuffer
from rt.embree.sampling import PixelRng
from rt.embree.shading import SceneData
from rt.embree.tracer import Tracer
from rt.pass_base import SPECULAR


def no_image(channels: int) -> np.ndarray:
    """The empty stand-in for an output image nobody reads (RtFrame.aux_image)."""
    return np.empty((0, channels), np.float32)


@dataclass
class RtFrame:
    data: SceneData
    tracer: Tracer
    gb: CpuGBuffer
    environment: object  # scenes.model.Environment
    options: object  # app.options.Options
    seed: int = 0
    index: int = 0  # frame index since the last reset
    # full-image outputs kept from frame to frame (the renderer's): fresh 10 MB arrays cost page
    # faults worth a few ms each, every frame. A frame's outputs are valid until the next frame.
    buffers: dict | None = None
    keys: dict = field(default_factory=dict)  # random stream -> every covered pixel's key (for_chunks)
    # whether the passes make their images besides radiance (Pass.writes: rt_direct, rt_ao, ...).
    # The display reads radiance alone, so the renderer asks for the others only when told to
    # (Renderer.pass_outputs); without them a pass writes one full image a frame, not two.
    aux: bool = True
    # whether they write their first hit's specular part (rt_specular: the denoisers filter it
    # apart from the diffuse, rt/pass_base.py SPECULAR), which only a denoiser reads
    specular: bool = False

    @property
    def ggx(self) -> bool:
        """Whether surfaces shade with glTF's GGX BRDF (option brdf, rt/embree/brdf.py)."""
        return self.data.scene.uses_ggx(self.options.get("brdf"))

    def rng(self, stream: int) -> PixelRng:
        """Per-pixel generator for the covered pixels, seeded from (seed, frame, pixel, stream)."""
        return PixelRng(self.seed, self.index, self.gb.index, stream)

    def background(self) -> np.ndarray:
        """(N,3) image holding the environment's radiance; passes fill in covered pixels."""
        from rt.embree.gather import env_args
        from rt.embree.kernels import background_fill

        out = self._buffer("background", 3)
        background_fill(out, self.gb.view_dir, self.gb.covered, *env_args(self.environment))
        return out

    def frame_outputs(self, channels: int = 3, fill=0.0, name: str = "") -> tuple[np.ndarray, np.ndarray]:
        """background() and image(channels, fill, name) for a whole-frame kernel that writes
        every covered pixel and fills the others as it goes (gather.fill_uncovered): left
        unfilled here, which saves two passes over the whole image before the frame. With no
        covered pixel there is no block to fill them, so they come back filled."""
        if len(self.gb.index) == 0:
            return self.background(), self.aux_image(channels, fill, name)
        aux = self._buffer(f"image{channels}{name}", channels) if self.aux else no_image(channels)
        return self._buffer("background", 3), aux

    def kernel_frame(self, out: np.ndarray, aux: np.ndarray, spec: np.ndarray | None = None):
        """This frame as the whole-frame kernels read it (kernel_args.FrameArgs), writing into
        out and aux (frame_outputs), and spec (specular_image) where the pass makes it."""
        from rt.embree.gather import env_args
        from rt.embree.kernel_args import FrameArgs
        from rt.environment import env_dist_args

        return FrameArgs(self.gb.soa, self.gb.index, self.gb.view_dir, self.gb.surface.arrays(),
                         env_args(self.environment), env_dist_args(self.environment), self.tracer.frame_target(), out,
                         aux, no_image(3) if spec is None else spec)

    def specular_image(self) -> np.ndarray:
        """The first hit's specular radiance (rt_specular, zero where the kernels write none:
        the sky, Lambert surfaces), or where no denoiser asks for it an empty (0, 3) array."""
        return self.image(3, 0.0, "specular") if self.specular else no_image(3)

    def aux_image(self, channels: int = 3, fill=0.0, name: str = "") -> np.ndarray:
        """image(channels, fill, name) for a pass's output besides radiance, or when the frame
        makes radiance only (aux False) an empty (0, channels) array: the kernels and
        ChunkFrame.put write nothing into it."""
        return self.image(channels, fill, name) if self.aux else no_image(channels)

    def outputs(self, radiance: np.ndarray, specular: np.ndarray | None = None, **aux) -> dict:
        """A pass's results: radiance, its other images (by name) when the frame makes them, and
        its specular part (specular_image) when asked."""
        found = {"radiance": radiance, **(aux if self.aux else {})}
        if self.specular and specular is not None:
            found[SPECULAR] = specular
        return found

    def for_chunks(self, work, streams: tuple = ()) -> None:
        """work(ChunkFrame) for runs of covered pixels, on the tracer's threads (chunks sized by
        what the same work, named by its qualified name, cost in the last frame).
        streams: the random streams the chunks draw from (ChunkFrame.rng). Their keys are made
        here for every pixel at once, so that a chunk starts tracing without first computing
        them: on many threads each chunk's short GIL-holding steps queue behind the others'."""
        self.keys = {s: self._keys(s) for s in streams}
        self.tracer.map_chunks(len(self.gb.surface), lambda c, tracer: work(ChunkFrame(self, c, tracer)),
                               key=getattr(work, "__qualname__", None))

    def key_base(self, stream: int) -> np.uint64:
        """What the pixels' keys for a random stream hash their ids with (blocks.block_keys: the
        whole-frame kernels make each block's keys from it)."""
        from rt.embree.sampling import key_base

        return key_base(self.seed, self.index, stream)

    def _keys(self, stream: int) -> np.ndarray:
        n = len(self.gb.index)
        name = f"keys{stream}"
        if self.buffers is None:
            out = np.empty(n, np.uint64)
        else:
            out = self.buffers.get(name)
            if out is None or out.shape != (n,):
                out = self.buffers[name] = np.empty(n, np.uint64)
        return PixelRng(self.seed, self.index, self.gb.index, stream, out=out).key

    def image(self, channels: int = 3, fill=0.0, name: str = "") -> np.ndarray:
        """An (N, channels) full-image array filled with `fill`, for chunks to write their pixels
        into; name: which of the frame's outputs it is (one buffer per name and size)."""
        from rt.embree.kernels import fill_rows

        out = self._buffer(f"image{channels}{name}", channels)
        fill_rows(out, np.float32(fill))
        return out

    def _buffer(self, name: str, channels: int) -> np.ndarray:
        shape = (self.gb.n, channels)
        if self.buffers is None:
            return np.empty(shape, np.float32)
        buf = self.buffers.get(name)
        if buf is None or buf.shape != shape:
            buf = self.buffers[name] = np.empty(shape, np.float32)
        return buf

    def full(self, values: np.ndarray, fill=0.0) -> np.ndarray:
        """Scatter per-covered-pixel values into a full image array."""
        from rt.embree.kernels import scatter_rows

        out = np.full((self.gb.n,) + values.shape[1:], fill, np.float32)
        v = np.ascontiguousarray(values, np.float32)
        width = int(np.prod(values.shape[1:]))  # not -1: no pixel covered is a shape (0, ...) too
        scatter_rows(out.reshape(self.gb.n, width), self.gb.index, v.reshape(v.shape[0], width))
        return out


class ChunkFrame:
    """An RtFrame restricted to a run c of its covered pixels, with a tracer for this thread."""

    def __init__(self, rf: RtFrame, c: slice, tracer: Tracer):
        self.frame, self.c, self.tracer = rf, c, tracer
        self.data, self.environment, self.options = rf.data, rf.environment, rf.options
        self.s = rf.gb.surface.take(c)  # views
        self.idx = rf.gb.index[c]

    @property
    def soa(self) -> tuple[np.ndarray, int]:
        """These points as the ray generators read them (Surface.soa): the G-buffer's rows,
        from this chunk's first column."""
        gb = self.frame.gb
        return (gb.soa, self.c.start) if gb.soa is not None else self.s.soa("chunk.soa")

    @property
    def view(self) -> np.ndarray:
        """(M,3) unit directions from the eye to these pixels' surfaces."""
        return self.frame.gb.view_dir[self.idx]

    def rng(self, stream: int) -> PixelRng:
        """As RtFrame.rng, for this chunk's pixels: its part of the frame's keys when for_chunks
        made them for this stream, else keys made here in this thread's scratch buffer for the
        stream (valid until the thread's next chunk)."""
        from rt.embree import scratch

        made = self.frame.keys.get(stream)
        if made is not None:  # made for the whole frame by for_chunks
            return PixelRng.of_keys(made[self.c])
        keys = scratch.buffer(f"rng{stream}", (len(self.idx),), np.uint64)
        return PixelRng(self.frame.seed, self.frame.index, self.idx, stream, out=keys)

    def put(self, image: np.ndarray, values: np.ndarray) -> None:
        """Write per-pixel values of this chunk into a full image from RtFrame.image() (nothing
        into an empty one: RtFrame.aux_image)."""
        from rt.embree.kernels import scatter_rows

        if image.shape[0] == 0:
            return
        v = np.ascontiguousarray(values, np.float32)
        scatter_rows(image, self.idx, v.reshape(v.shape[0], -1))
